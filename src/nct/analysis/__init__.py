"""Many runs: sweep reports and benchmarking."""
