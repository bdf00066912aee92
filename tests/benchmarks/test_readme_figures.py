"""benchmarks/readme_figures.py: the README's movie frame is the middle picture of the run's movie, in colour
channels even where the GIF holds grey levels."""

from __future__ import annotations

import numpy as np

from nct.run.export import movie_pictures, save_movie
from tests.conftest import load_benchmark as load_script

readme_figures = load_script("readme_figures")


def test_movie_frame_is_the_middle_picture(tmp_path):
    rng = np.random.default_rng(0)
    frames = {name: rng.random((3, 16, 16)).astype(np.float32) for name in ("truth", "fbp", "nct")}
    times = np.array([0.0, 0.1, 0.2])
    save_movie(tmp_path / "movie.gif", frames, times, fps=8, extent=1.0)
    np.testing.assert_array_equal(readme_figures.movie_frame(tmp_path / "movie.gif"),
                                  movie_pictures(frames, times, 1.0)[1])
