"""What a card cannot tell: a resonance on the stroke or beyond the samples."""

from __future__ import annotations

import dataclasses
import math

from pumpid.inference.derived import Derived
from pumpid.inference.echo import alias_of, echo_of


def _pair(fn: float, zeta: float = 0.05) -> dict[str, Derived]:
    return {
        "natural_frequency": Derived("natural_frequency", fn, "Hz", 0.1 * fn, 0.1 * fn, True,
                                     "undamped natural frequency"),
        "damping_ratio": Derived("damping_ratio", zeta, "1", 0.001, 0.001, True,
                                 "damping ratio"),
        "static_stiffness": Derived("static_stiffness", 80.0, "N/m", 1.0, 1.0, True,
                                    "static stiffness"),
    }


def test_a_resonance_beyond_half_the_sampling_rate_is_marked() -> None:
    derived, words = alias_of(_pair(478.0), 0.05)
    assert words is not None and "(10 Hz, half their rate)" in words
    for name in ("natural_frequency", "damping_ratio"):
        d = derived[name]
        assert not d.determined and not d.well_property and "478 Hz" in d.note
        # The errors stay what they were: the note says why the value is not determined.
        assert d.stderr == _pair(478.0)[name].stderr
    assert derived["static_stiffness"].determined and derived["static_stiffness"].well_property


def test_a_resonance_the_samples_show_is_left_alone() -> None:
    for fn, step in ((9.9, 0.05), (478.0, None), (478.0, math.nan), (math.inf, 0.05)):
        derived, words = alias_of(_pair(fn), step)
        assert words is None, (fn, step)
        assert derived["natural_frequency"].determined
    assert alias_of({}, 0.05) == ({}, None)
    # Two real poles (a boundary fit's "pair" at an arbitrary k0, damping ratio 569) do not
    # ring: there is no alias to lend.
    assert alias_of(_pair(610.0, zeta=569.0), 0.04)[1] is None
    # A frequency set by a limit (no finite error) is left to the limit's words.
    at_limit = _pair(615.0, zeta=0.01)
    at_limit["natural_frequency"] = dataclasses.replace(at_limit["natural_frequency"],
                                                        stderr=math.inf)
    assert alias_of(at_limit, 0.05)[1] is None


def test_an_echo_and_an_alias_are_told_apart() -> None:
    # On the stroke frequency: an echo, well within what 20 samples a second show.
    derived, words = echo_of(_pair(0.105), 10.0)
    assert words is not None and not derived["natural_frequency"].well_property
    assert derived["natural_frequency"].determined
    assert alias_of(_pair(0.105), 0.05)[1] is None
