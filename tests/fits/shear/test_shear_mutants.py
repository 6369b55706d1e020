"""The three-point-bend fit's rules against hand-made cases, for what the mutation sample
(benchmarks/mutation.sh, seed 29) showed no other test sees."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from matid.fits.shear.fit import _bias_explains


@pytest.mark.parametrize(
    ("widen", "ratio", "explained"),
    [
        (1.5, 0.8, True),  # the bias warned of (E_s at 0.6-0.9 of its value) spans the ratio
        (1.5, 0.5, False),  # farther than the bias: a second fact, its own warning
        (1.5, 1.2, False),  # on the other side of the bias
        (1.0, 0.8, False),  # no bias warned of: nothing explains the disagreement
    ],
)
def test_a_torsion_disagreement_is_explained_only_within_the_warned_bias(widen, ratio, explained) -> None:
    check = SimpleNamespace(widen=widen, info={"nose_bias_ratio": [0.6, 0.9]} if widen > 1 else {})
    assert _bias_explains(check, ratio) is explained
