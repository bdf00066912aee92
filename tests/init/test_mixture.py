"""Algorithm 1's mixture: its one-dimensional labels are the mixture's own, and a broad class claims
the level of the pixels it holds."""

from __future__ import annotations

import numpy as np
from sklearn.mixture import GaussianMixture

from nct.init.mixture import MixtureClasses, claimed_levels, class_choices, predict_1d
from tests.conftest import two_object_frames


def test_one_dimensional_labels_are_those_of_the_mixture():
    """predict_1d (used for the million pixels of a run) labels as GaussianMixture.predict does,
    chunked or not, on overlapping classes where the boundaries matter."""
    images, _ = two_object_frames(noise=0.2)
    values = images.reshape(-1)
    gmm = GaussianMixture(6, n_init=2, random_state=0).fit(values[::3, None].astype(np.float64))
    expected = gmm.predict(values[:, None].astype(np.float64))
    assert len(np.unique(expected)) >= 4
    np.testing.assert_array_equal(predict_1d(gmm, values), expected)
    np.testing.assert_array_equal(predict_1d(gmm, values, chunk=1000), expected)


def test_a_broad_class_on_another_peak_stands_for_the_pixels_it_claims():
    """A mixture class whose mean sits under a sharp class's peak (a small nodule's few pixels taken
    by a broad class centred on the body's level) claims the median of its pixels as its level, and
    the judge's choices offer both; classes that claim their own mean keep it."""
    rng = np.random.default_rng(0)
    values = np.concatenate([0.01 * rng.standard_normal(5000), 1 + 0.01 * rng.standard_normal(5000),
                             2 + 0.01 * rng.standard_normal(50)])
    gmm = GaussianMixture(3)
    gmm.means_ = np.array([[0.0], [1.0], [1.01]])
    gmm.covariances_ = np.array([0.01, 0.01, 0.5]).reshape(3, 1, 1) ** 2
    gmm.weights_ = np.array([0.5, 0.49, 0.01])
    labels = predict_1d(gmm, values)
    assert predict_1d(gmm, np.array([1.01]))[0] == 1 and (labels[-50:] == 2).all()
    claimed = claimed_levels(gmm, values, labels)
    np.testing.assert_allclose(claimed, [0.0, 1.0, 2.0], atol=0.01)
    classes = MixtureClasses(gmm.means_[:, 0], np.array([0.01, 0.01, 0.5]), np.bincount(labels), 0, 0.5, claimed)
    assert sorted(c[1] for c in class_choices(classes, 1)) == [1.0, 1.01, claimed[2]]
