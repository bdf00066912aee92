"""Files for people: the movie's time label stays clear of the panels and their labels."""

from pathlib import Path

import imageio.v3 as iio
import numpy as np

from nct.run.export import movie_figure, save_movie


def frames(n: int = 4, size: int = 16) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    return {name: rng.random((n, size, size)).astype(np.float32) for name in ("truth", "fbp", "nct")}


def test_movie_time_label_is_clear_of_panel_titles_and_images():
    times = np.array([0.0125, 0.0625, 0.1875, 1.2345])
    fig, images, label = movie_figure(frames(), times)
    renderer = fig.canvas.get_renderer()
    assert label.get_text() == "t = 1234 ms"  # laid out for the longest label
    box = label.get_window_extent(renderer)
    for ax in fig.axes:
        assert not box.overlaps(ax.title.get_window_extent(renderer)), ax.title.get_text()
        assert not box.overlaps(ax.get_window_extent(renderer))
    assert [ax.title.get_text() for ax in fig.axes] == ["truth", "fbp", "nct"] and len(images) == 3


def test_movie_has_a_picture_per_frame_at_fixed_size(tmp_path: Path):
    path = tmp_path / "movie.gif"
    save_movie(path, frames(), np.array([0.0, 0.05, 0.1, 0.15]), fps=8)
    movie = iio.imread(path, index=None)
    assert movie.shape[0] == 4 and movie.shape[-1] == 3
    assert not np.array_equal(movie[0], movie[1])  # the frames (and the label) change
