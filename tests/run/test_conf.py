"""The run wing's settings: the objects to fit are chosen from the data unless a whole number is given."""

from functools import partial

import pytest

from nct.run.conf import FileConf, SimulateConf, chosen_objects


@pytest.mark.parametrize("conf", [SimulateConf, partial(FileConf, path="x.npz")])
def test_the_objects_to_fit_are_chosen_from_the_data_unless_a_whole_number_is_given(conf):
    assert conf(n_objects=2).n_objects == 2 and conf().n_objects == "auto"
    assert chosen_objects("auto") is None and chosen_objects(3) == 3
    for bad in (0, -1, 1.5, "two", True):
        with pytest.raises(ValueError, match=r"data\.n_objects must be auto or a whole number >= 1"):
            conf(n_objects=bad)
