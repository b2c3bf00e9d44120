"""Joint fits: one parameter set for several strokes of a well, an offset per card."""

from __future__ import annotations

import math

import numpy as np
import pytest

import pumpid
from pumpid.cards import read_cards
from pumpid.cli import main
from pumpid.pump import fit_joint
from pumpid.pump.synthetic import synthetic_card

EXAMPLE = pumpid.__path__[0] + "/data/example_cards.csv"
TRUTH = pumpid.Kelvin(k0=200.0, m=8.8, c1=40.0, k1=130.0)  # the example's generator


def steady_well(n: int) -> list:
    rng = np.random.default_rng(0)
    return [synthetic_card(TRUTH, spm=8.0 * (1 + 0.01 * rng.standard_normal()),
                           n_samples=130, observe="u", noise=0.003, seed=rng,
                           card_id=f"s{i}") for i in range(n)]


def test_the_example_strokes_give_the_truth_within_their_errors() -> None:
    joint = fit_joint(read_cards(EXAMPLE))
    assert joint.status == "converged" and len(joint.cards) == 2
    for name, value in TRUTH.as_dict().items():
        assert abs(joint.params[name] - value) <= 3 * joint.stderr[name], name
    assert joint.derived["static_stiffness"][0] == pytest.approx(
        1 / (1 / 200.0 + 1 / 130.0), rel=0.01)
    assert all(r2 > 0.9999 for r2 in joint.r2)
    as_json = joint.to_dict()
    assert as_json["joint"] is True and set(as_json["params"]) == set(TRUTH.as_dict())
    assert "one parameter set for 2 cards" in joint.report()


def test_errors_shrink_about_as_one_over_the_root_of_the_number_of_cards() -> None:
    well = steady_well(16)
    few, many = fit_joint(well[:4]), fit_joint(well)
    for name in ("m", "c1", "k1"):
        ratio = many.stderr_white[name] / few.stderr_white[name]
        assert 0.3 <= ratio <= 0.8, (name, ratio)  # 1 / sqrt(4) = 0.5


def test_bad_requests_are_refused() -> None:
    cards = read_cards(EXAMPLE)
    with pytest.raises(ValueError, match="at least two"):
        fit_joint(cards[:1])
    with pytest.raises(ValueError, match="different units"):
        fit_joint([cards[0], cards[1].to_units(position="m")])


def test_the_cli_fits_the_files_cards_jointly(capsys) -> None:
    assert main(["fit", EXAMPLE, "--joint"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("joint fit: Kelvin observing u") and "EX-1A" in out
    assert main(["fit", EXAMPLE, "--joint", "--model", "auto"]) == 2


@pytest.mark.realdata
def test_a_parameter_the_strokes_do_not_hold_is_not_called_converged(shared_raw) -> None:
    # Sandia's downhole record split into its strokes: the joint fit used to stop anywhere
    # along the limits and call it converged (on a real well: k0 = 3.6e10 +- 9.3e13).
    from pumpid.cards import split_strokes

    record = read_cards(shared_raw / "sandia_dds" / "downhole_timeseries.csv")[0]
    joint = fit_joint(split_strokes(record))
    assert joint.status in ("boundary", "undetermined"), joint.message
    assert joint.shown == "robust" and joint.to_dict()["errors_shown"] == "robust"
    report = joint.report()
    for name, value in joint.params.items():
        se = joint.stderr[name]
        if se == math.inf:
            assert "held at its limit" in joint.message
        elif se > abs(value):  # shown, and said, as not determined
            line = next(ln for ln in report.splitlines() if ln.strip().startswith(name))
            assert "not determined" in line, line
        assert joint.stderr_white[name] <= se
