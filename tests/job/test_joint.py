"""Joint fits: one parameter set for several strokes of a well, a level per card, through
``pumpid.fit(..., options=FitOptions.for_cards(joint=True))``."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import pumpid
from pumpid.cards import read_cards
from pumpid.cli import main
from pumpid.pump.synthetic import CardLabel, synthetic_card

EXAMPLE = pumpid.__path__[0] + "/data/example_cards.csv"
TRUTH = pumpid.Kelvin(k0=200.0, m=8.8, c1=40.0, k1=130.0)  # the example's generator
JOINT = pumpid.FitOptions.for_cards(joint=True)


def steady_well(n: int) -> list:
    rng = np.random.default_rng(0)
    return [synthetic_card(TRUTH, spm=8.0 * (1 + 0.01 * rng.standard_normal()),
                           n_samples=130, observe="u", noise=0.003, seed=rng,
                           label=CardLabel(card_id=f"s{i}")) for i in range(n)]


def test_the_example_strokes_give_the_truth_within_their_errors() -> None:
    joint = pumpid.fit(pumpid.Kelvin, read_cards(EXAMPLE), options=JOINT)
    assert isinstance(joint, pumpid.FitResult)
    assert joint.status is pumpid.Status.CONVERGED, joint.reason
    part = joint.application["joint"]
    assert [c["card"] for c in part["cards"]] == ["EX-1A", "EX-1B"]
    for name, value in TRUTH.as_dict().items():
        assert abs(joint.params[name] - value) <= 3 * joint.stderr[name], name
    assert joint.derived["static_stiffness"].value == pytest.approx(
        1 / (1 / 200.0 + 1 / 130.0), rel=0.01)
    assert all(c["r2"] > 0.9999 for c in part["cards"])
    # Each card's offset at zero load is its level less the mean response.
    alone = [pumpid.fit(pumpid.Kelvin, c) for c in read_cards(EXAMPLE)]
    for c, own in zip(part["cards"], alone, strict=True):
        assert c["offset"] == pytest.approx(own.offset, abs=0.02 * abs(own.offset) + 1e-3)
    assert "joint" in joint.to_json() and "(joint, 2 cards)" in joint.report()


def test_errors_shrink_about_as_one_over_the_root_of_the_number_of_cards() -> None:
    well = steady_well(16)
    few = pumpid.fit(pumpid.Kelvin, well[:4], options=JOINT)
    many = pumpid.fit(pumpid.Kelvin, well, options=JOINT)
    for name in ("m", "c1", "k1"):
        ratio = (many.uncertainty.stderr_white[name] / few.uncertainty.stderr_white[name])
        assert 0.3 <= ratio <= 0.8, (name, ratio)  # 1 / sqrt(4) = 0.5


def test_bad_requests_are_refused() -> None:
    cards = read_cards(EXAMPLE)
    with pytest.raises(ValueError, match="at least two"):
        pumpid.fit(pumpid.Kelvin, cards[:1], options=JOINT)
    with pytest.raises(ValueError, match="different units"):
        pumpid.fit(pumpid.Kelvin, [cards[0], cards[1].to_units(position="m")], options=JOINT)
    with pytest.raises(ValueError, match="fixed scale"):
        pumpid.fit(pumpid.Kelvin, cards, options=JOINT.replace(scale="free"))
    # Cards that say they come from two wells are not one rod string.
    two = [dataclasses.replace(c, well_id=w) for c, w in zip(cards, ("W-1", "W-2"),
                                                               strict=True)]
    with pytest.raises(ValueError, match=r"2 wells \('W-1', 'W-2'\)"):
        pumpid.fit(pumpid.Kelvin, two, options=JOINT)
    same = [dataclasses.replace(c, well_id="W-1") for c in cards]
    assert pumpid.fit(pumpid.Kelvin, same, options=JOINT).status.key == "converged"


def test_the_cli_fits_the_files_cards_jointly(capsys) -> None:
    assert main(["fit", EXAMPLE, "--joint"]) == 0
    out = capsys.readouterr().out
    assert "Kelvin (joint, 2 cards)" in out and "EX-1A" in out
    # Each card's own fit is said with its units, like every other number.
    alone = [ln.split("alone: ")[1] for ln in out.splitlines() if "alone: " in ln]
    assert len(alone) == 2 and all("lbf/in" in a and "lbf*s^2/in" in a for a in alone)
    assert main(["fit", EXAMPLE, "--joint", "--model", "auto"]) == 2
    # --brief's line per card has no place for one fit of several cards: it was ignored.
    assert main(["fit", EXAMPLE, "--joint", "--brief"]) == 2
    assert "--brief" in capsys.readouterr().err


@pytest.mark.realdata
def test_a_cards_offset_is_flagged_where_the_joint_static_stiffness_is_not(shared_raw,
                                                                          capsys) -> None:
    # Sandia's SX6I03 pair: k1 and the static stiffness not determined, and each card's
    # offset at zero load (its level less the mean load over that stiffness) printed as
    # -74.9981 in, unflagged, where the card's own fit calls its offset not determined.
    main(["fit", str(shared_raw / "sandia_dds" / "surface_cards.csv"), "--card", "SX6I03A",
          "--card", "SX6I03B", "--joint"])
    out = capsys.readouterr().out
    per_card = [ln for ln in out.splitlines() if ln.strip().startswith("SX6I03") and "level" in ln]
    assert len(per_card) == 2
    assert all("in (not determined), R^2" in ln for ln in per_card), per_card
    assert "static_stiffness" in out
    main(["fit", str(shared_raw / "sandia_dds" / "surface_cards.csv"), "--card", "SX6I03A",
          "--card", "SX6I03B", "--joint", "--json"])
    doc = json.loads(capsys.readouterr().out)
    assert [c["offset_determined"] for c in doc["cards"]] == [False, False]


@pytest.mark.realdata
def test_a_parameter_the_strokes_do_not_hold_is_not_called_converged(shared_raw) -> None:
    # Sandia's downhole record split into its strokes: the old joint fit stopped anywhere
    # along the limits and called it converged (on a real well: k0 = 3.6e10 +- 9.3e13).
    from pumpid.cards import split_strokes

    record = read_cards(shared_raw / "sandia_dds" / "downhole_timeseries.csv")[0]
    joint = pumpid.fit(pumpid.Kelvin, split_strokes(record), options=JOINT)
    assert joint.status in (pumpid.Status.BOUNDARY, pumpid.Status.UNDETERMINED), joint.reason
    assert joint.uncertainty.shown == "robust"
    determined = set(joint.determined.get("parameters", []))
    for name in pumpid.Kelvin.param_names():
        se = joint.stderr[name]
        if name in determined:
            assert se <= abs(joint.params[name])
        assert not joint.uncertainty.stderr_white[name] > se


@pytest.mark.realdata
def test_a_stiffness_deep_in_its_rigid_limit_runs_to_infinity(shared_raw) -> None:
    # Sandia's four surface cards jointly: k0 ends at 3e14 (rigid). Pushed up a further
    # factor 1000 the simulation no longer resolves it and the cost jumped, pushed down it
    # stayed flat, and the joint fit said "k0 runs to zero ... only an upper bound exists".
    cards = read_cards(shared_raw / "sandia_dds" / "surface_cards.csv")
    joint = pumpid.fit(pumpid.Kelvin, cards, options=JOINT)
    k0 = [b for b in joint.boundary.limits if b.name == "k0"]
    assert k0 and k0[0].direction == "infinity", joint.boundary
    assert not any("k0 -> 0" in s for s in joint.identifiability)


@pytest.mark.realdata
@pytest.mark.parametrize("pair", ["SX6I03", "SX6E03"])
def test_a_pairs_rigid_stiffness_runs_to_infinity(shared_raw, pair: str) -> None:
    # Each Sandia pair jointly: k0 ends at 4e12-6e12, 20x its start. Pushed up a factor
    # 1000 the cost rose by 17 (rounding, within the noise), pushed down by 0.015: the
    # limit was taken as k0 -> 0, "only an upper bound exists", while each card alone and
    # the four together run to infinity.
    cards = [c for c in read_cards(shared_raw / "sandia_dds" / "surface_cards.csv")
             if str(c.card_id).startswith(pair)]
    joint = pumpid.fit(pumpid.Kelvin, cards, options=JOINT)
    k0 = [b for b in joint.boundary.limits if b.name == "k0"]
    assert k0 and k0[0].direction == "infinity", joint.boundary
    assert not any("k0 -> 0" in s or "upper bound" in s for s in joint.identifiability)
    assert not any("runs to zero" in w for w in joint.warnings)


@pytest.mark.realdata
def test_a_joint_resonance_on_the_stroke_frequency_is_named(shared_raw) -> None:
    # SX6I03's two strokes: 0.136 Hz jointly, 0.96x the stroke frequency, as each card
    # alone, where it is named an echo of the pumping speed; jointly it was "determined"
    # and a property of the well, trended by the fleet report.
    cards = [c for c in read_cards(shared_raw / "sandia_dds" / "surface_cards.csv")
             if str(c.card_id).startswith("SX6I03")]
    joint = pumpid.fit(pumpid.Kelvin, cards, options=JOINT)
    alone = pumpid.fit(pumpid.Kelvin, cards[0])
    assert not alone.derived["natural_frequency"].well_property
    fn = joint.derived["natural_frequency"]
    assert 0.75 < fn.value * cards[0].period < 1.25
    assert not fn.well_property and not joint.derived["damping_ratio"].well_property
    assert joint.determined["not_well_property"] == ["natural_frequency", "damping_ratio"]
    assert any("sits on the stroke frequency" in w for w in joint.warnings)
    assert joint.to_dict()["derived"]["natural_frequency"]["well_property"] is False


@pytest.mark.realdata
def test_a_levels_error_is_said_relative_to_the_datas_range(shared_raw) -> None:
    # A card's level is a signed position: its error in the identifiability sentences was
    # its error in position units read as a fraction. On Sandia's surface cards each level's
    # error is a quarter to a half of its value (a fifth of the data's range or less), and
    # "level_4 is practically not identifiable: ... a standard error of 1934 %" (19.34 in).
    cards = read_cards(shared_raw / "sandia_dds" / "surface_cards.csv")
    joint = pumpid.fit(pumpid.Kelvin, cards, options=JOINT)
    spread = float(np.ptp(joint.data))
    levels = [n for n in joint.params if n.startswith("level_")]
    assert levels and all(joint.stderr[n] < 0.3 * spread for n in levels)
    for sentence in joint.identifiability:
        if any(n in sentence for n in levels) and "standard error of" in sentence:
            assert "in units of the data range" in sentence
            percent = float(sentence.split("standard error of ")[1].split(" %")[0])
            assert percent < 100.0 * max(joint.stderr[n] for n in levels) / spread * 3
        assert not any(sentence.startswith(f"{n} is practically") for n in levels)


def test_cards_that_share_no_parameter_set_are_named() -> None:
    # Four cards of two wells without well ids: the joint fit was a poor fit that said
    # nothing of why. Each card it describes far worse than its own fit is now named.
    other = pumpid.Kelvin(k0=900.0, m=3.0, c1=120.0, k1=40.0)
    apart = [synthetic_card(other, spm=8.0, n_samples=130, observe="u", noise=0.003,
                            seed=i, label=CardLabel(card_id=f"o{i}")) for i in range(2)]
    mixed = pumpid.fit(pumpid.Kelvin, [*steady_well(2), *apart], options=JOINT)
    said = [w for w in mixed.warnings if "fit jointly more than 1.5x worse" in w]
    assert len(said) == 1
    part = mixed.application["joint"]["cards"]
    named = [c["card"] for c in part if c["rmse"] > 1.5 * c["rmse_alone"]]
    assert named and all(card in said[0] for card in named)
    steady = pumpid.fit(pumpid.Kelvin, steady_well(4), options=JOINT)
    assert not any("fit jointly" in w for w in steady.warnings)
    assert all(c["rmse"] <= 1.1 * c["rmse_alone"] for c in steady.application["joint"]["cards"])


def test_records_from_a_given_state_are_not_checked_for_an_echo() -> None:
    # Records started from a given state (an array) are not one period of a stroke: the
    # echo check compared the array with "periodic" and raised instead of fitting.
    from pumpid.engine.problem import CardData

    t = np.linspace(0.0, 20.0, 201)
    truth = pumpid.Kelvin(k0=40.0, m=1.0, c1=2.0, k1=30.0)
    records = []
    for amp in (3.0, 3.3):
        load = 10.0 + amp * np.sin(0.9 * t) + np.sin(2.3 * t)
        u = pumpid.simulate(truth, t, load, observe="u")
        records.append(CardData(t, load, u, np.zeros(3), None))
    joint = pumpid.fit(pumpid.Kelvin, records, options=JOINT)
    assert joint.status in (pumpid.Status.CONVERGED, pumpid.Status.BOUNDARY), joint.reason
    assert all(d.well_property for d in joint.derived.values())
    assert not any("stroke frequency" in w for w in joint.warnings)


@pytest.mark.realdata
def test_a_joint_resonance_beyond_the_samples_is_not_determined(shared_raw) -> None:
    # A joint fit checks its pair against its coarsest card's samples, as a card's fit does
    # (pumpid.inference.echo.alias_of): a pair ringing at 478 Hz with a finite error, on
    # cards sampled about 11 times a second.
    cards = read_cards(shared_raw / "sandia_dds" / "surface_cards.csv")[:2]
    fit = pumpid.fit(pumpid.Kelvin, cards,
                     options=dataclasses.replace(pumpid.FitOptions.for_cards(), joint=True))
    step = max(float(np.median(np.diff(c.t))) for c in cards)
    derived = {
        "natural_frequency": dataclasses.replace(fit.derived["natural_frequency"],
                                                 value=478.0, stderr=238.0, determined=True),
        "damping_ratio": dataclasses.replace(fit.derived["damping_ratio"], value=0.0015,
                                             stderr=0.002, determined=True),
    }
    marked, words = fit.model.echo(derived)
    assert words is not None and f"({0.5 / step:.4g} Hz, half their rate)" in words
    assert not any(d.determined or d.well_property for d in marked.values())
    # Within the samples, the echo check runs as before.
    calm = {n: dataclasses.replace(d, value=v) for (n, d), v in
            zip(derived.items(), (1.0 / cards[0].period, 0.05), strict=True)}
    assert "the model echoes the imposed motion" in fit.model.echo(calm)[1]


@pytest.mark.realdata
def test_a_joint_boundary_fit_reaches_back_from_its_limit(shared_raw) -> None:
    # A single card's boundary fit holds its limit's parameter back from the limit as far
    # as the noise allows, and every other value's error reaches that far; a joint fit (an
    # own model) did not: its independent-noise errors were those with k0 at its limit
    # (c1 +- 0.186 lbf*s/in on SX6E03's pair) and no sentence said how far k0 comes back.
    cards = {c.card_id: c for c in read_cards(shared_raw / "sandia_dds" / "surface_cards.csv")}
    joint = pumpid.fit(pumpid.Kelvin, [cards["SX6E03A"], cards["SX6E03B"]], options=JOINT)
    assert joint.status is pumpid.Status.BOUNDARY and joint.errors_shown == "robust"
    (words,) = [f for f in joint.identifiability if f.startswith("k0 fits within the noise")]
    dof = joint.data.size - len(joint.free)
    assert f"the noise the robust errors describe ({dof} times the independent-noise" in words
    held = float(words.split(" down to ")[1].split(" ")[0])
    assert held < 1e4 < joint.params["k0"]
    assert joint.stderr_white["c1"] > 1.0 and joint.stderr["c1"] >= joint.stderr_white["c1"]
