"""How a scene becomes a sinogram: the differentiable projector, FBP and the data term."""
