"""Files for people: every picture a run writes explains itself (title, labels with units, a
colourbar or a legend that covers no data), and the movie's time label stays clear of the panels."""

from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest
import tifffile

from nct.run.export import (
    metric_figure,
    movie_figure,
    movie_pictures,
    save_movie,
    save_tiffs,
    strip_figure,
    time_label,
    trace_figure,
)
from nct.run.metrics import frame_metrics
from tests.conftest import figure_problems

EXTENT = 250.0  # a field of view in, say, mm: the axes must read in that unit, not in pixels
LENGTH = "length unit"
INTENSITY = "the data's unit"


def frames(n: int = 4, size: int = 16) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    return {name: rng.random((n, size, size)).astype(np.float32) for name in ("truth", "fbp", "nct")}


def test_strip_is_titled_scaled_in_length_units_and_has_a_colourbar():
    fig = strip_figure(frames(6), np.linspace(0, 0.5, 6), 4, EXTENT)
    assert figure_problems(fig, (LENGTH, INTENSITY)) == []
    rows = [ax for ax in fig.axes if ax.images]
    assert [ax.get_ylabel() for ax in rows] == ["truth", "fbp", "nct"]
    assert all(ax.get_ylim() == pytest.approx((-EXTENT / 2, EXTENT / 2)) for ax in rows)
    assert rows[0].get_xlim()[0] == pytest.approx(-EXTENT / 2)  # the first frame over its field of view


def test_strip_rows_hold_the_chosen_frames_side_by_side_under_their_times():
    shown, times = frames(6), np.linspace(0, 0.5, 6)
    fig = strip_figure(shown, times, 4, EXTENT)
    chosen = [0, 2, 3, 5]  # 4 of 6 frames, evenly spread
    rows = [ax for ax in fig.axes if ax.images]
    for ax, f in zip(rows, shown.values()):
        image = np.ma.masked_invalid(ax.images[0].get_array())
        kept = image[:, ~image.mask.all(axis=0)]  # the blank columns between frames left out
        np.testing.assert_array_equal(np.hsplit(kept.data, 4), f[chosen])
    labels = [t.get_text() for t in rows[0].texts]
    assert labels == [f"t = {times[i] * 1e3:.0f} ms" for i in chosen]


def test_metric_plot_names_its_units_and_its_legend_covers_no_curve():
    rng = np.random.default_rng(1)
    truth = np.zeros((8, 16, 16), np.float32)
    truth[:, 4:12, 4:12] = 0.02  # intensities in 1/mm: MSE ~1e-5
    scored = {name: frame_metrics(truth + rng.normal(0, s, truth.shape).astype(np.float32), truth, 0.01)
              for name, s in (("fbp", 0.004), ("nct", 0.001))}
    fig = metric_figure(np.linspace(0, 0.5, 8), scored)
    assert figure_problems(fig, ("intensity unit²", "dB", "ms")) == []
    assert [t.get_text() for t in fig.legends[0].get_texts()] == ["fbp", "nct"]


def test_trace_plot_is_titled_and_its_legend_covers_no_point():
    trace = [{"stage": stage, "seconds": s, "median_dice": d} for stage, s, d in
             (("coarse", 1.0, 0.2), ("coarse", 2.0, 0.98), ("fine", 3.0, 0.99), ("fine", 4.0, 0.995))]
    assert figure_problems(trace_figure(trace, 0.97), ("(s)",)) == []


def test_movie_is_scaled_in_length_units_and_has_a_colourbar():
    fig, _, _ = movie_figure(frames(), np.array([0.0, 0.1, 0.2, 0.3]), EXTENT)
    assert figure_problems(fig, (LENGTH, INTENSITY)) == []


def test_figure_problems_finds_what_an_unexplained_figure_lacks():
    """The checker itself can fail: a bare image, and a legend drawn over its curve."""
    from matplotlib.figure import Figure

    bare = Figure()
    bare.subplots().imshow(np.ones((4, 4)))
    assert set(figure_problems(bare, (LENGTH,))) == {"no title", "panel 0 has no x label", "panel 0 has no y label",
                                                     f"no label names the unit {LENGTH!r}",
                                                     "images without a colourbar"}
    covered = Figure()
    ax = covered.subplots()
    ax.plot(np.linspace(0, 1, 200), np.full(200, 0.5), label="curve")
    ax.set(title="t", xlabel="x", ylabel="y")
    ax.legend(loc="center")
    problems = figure_problems(covered)
    assert len(problems) == 1 and problems[0].startswith("a legend covers a point of panel 0")


def test_movie_time_label_is_clear_of_panel_titles_and_images():
    times = np.array([0.0125, 0.0625, 0.1875, 1.2345])
    fig, images, label = movie_figure(frames(), times, EXTENT)
    renderer = fig.canvas.get_renderer()
    assert label.get_text() == "t = 1234 ms"  # laid out for the longest label
    box = label.get_window_extent(renderer)
    panels = [ax for ax in fig.axes if ax.images]
    for ax in panels:
        assert not box.overlaps(ax.title.get_window_extent(renderer)), ax.title.get_text()
        assert not box.overlaps(ax.get_window_extent(renderer))
    assert [ax.title.get_text() for ax in panels] == ["truth", "fbp", "nct"] and len(images) == 3


def test_movie_has_a_picture_per_frame_at_fixed_size(tmp_path: Path):
    path = tmp_path / "movie.gif"
    times = np.array([0.0, 0.05, 0.1, 0.15])
    save_movie(path, frames(), times, fps=8, extent=EXTENT)
    movie = iio.imread(path, index=None, mode="RGB")
    assert movie.shape[0] == 4 and movie.shape[-1] == 3
    assert not np.array_equal(movie[0], movie[1])  # the frames (and the label) change
    np.testing.assert_array_equal(movie, movie_pictures(frames(), times, EXTENT))  # grey levels kept exactly


def test_movie_in_a_colour_style_keeps_its_colours(tmp_path: Path):
    """A style that colours the text makes pictures that are not grey: they are written in colour."""
    import matplotlib

    path, times = tmp_path / "movie.gif", np.array([0.0, 0.05])
    with matplotlib.rc_context({"text.color": "red", "axes.labelcolor": "red"}):
        save_movie(path, frames(2), times, fps=8, extent=EXTENT)
        pictures = movie_pictures(frames(2), times, EXTENT)
    movie = iio.imread(path, index=None, mode="RGB").astype(int)
    assert (movie[..., 0] > movie[..., 1] + 100).any()  # red text survives
    assert np.abs(movie - pictures).mean() < 2.0


def test_movie_pictures_are_a_full_draw_of_each_frame():
    """movie_pictures redraws only what changes; the pixels are those of drawing the whole figure anew."""
    times = np.array([0.0, 0.05, 0.1, 0.15])
    shown = frames()
    fig, images, label = movie_figure(shown, times, EXTENT)
    full = []
    for i, t in enumerate(times):
        for im, f in zip(images, shown.values()):
            im.set_data(f[i])
        label.set_text(time_label(t))
        fig.canvas.draw()
        full.append(np.asarray(fig.canvas.buffer_rgba())[..., :3].copy())
    np.testing.assert_array_equal(movie_pictures(shown, times, EXTENT), np.stack(full))


def test_tiff_stacks_carry_pixel_size_unit_and_frame_interval_for_imagej(tmp_path: Path):
    times = np.array([0.0, 0.02, 0.04, 0.06])
    save_tiffs(tmp_path, frames(4, 16), times, EXTENT)
    with tifffile.TiffFile(tmp_path / "nct.tiff") as tif:
        meta, page = tif.imagej_metadata, tif.pages[0]
        stack = tif.asarray()
        x, y = (page.tags[name].value for name in ("XResolution", "YResolution"))
    np.testing.assert_array_equal(stack, frames(4, 16)["nct"])
    assert meta["frames"] == 4 and meta["unit"] == "unit" and meta["finterval"] == pytest.approx(0.02)
    assert x[1] / x[0] == pytest.approx(EXTENT / 16, rel=1e-6) and y == x  # pixels per unit: 16 / 250
    save_tiffs(tmp_path / "one", {"nct": frames(1, 16)["nct"]}, times[:1], EXTENT)
    with tifffile.TiffFile(tmp_path / "one" / "nct.tiff") as tif:
        assert "finterval" not in tif.imagej_metadata
