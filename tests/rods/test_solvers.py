"""The diagnostic solvers against closed forms, against each other, and their bookkeeping."""

from __future__ import annotations

import numpy as np
import pytest

from pumpid.rods import (
    PumpModel,
    StringArrays,
    diagnose_card,
    diagnose_cards,
    fd_diagnostic,
    fourier_diagnostic,
    fourier_predict,
    predict_surface,
)

from .strings import INCH, LBF, card, surface_motion, three_tapers, uniform


def harmonic_string(nu: float, n: int = 200, period: float = 7.5):
    """A uniform rod driven by A cos(wt) at the top, pump load P0 + Re(P1 e^{iwt}).

    Written from the closed form of one rod (U = alpha cos kx + beta sin kx), not from the
    package's transfer matrices. Returns (well, t, surface position, surface load incl. the
    buoyant weight, pump position, effective pump load).
    """
    well = uniform()
    taper = well.tapers[0]
    length, ea, a = taper.length, taper.stiffness, taper.wave_speed
    omega = 2 * np.pi / period
    c = np.pi * nu / (2 * length / a)
    k = np.sqrt((omega**2 - 1j * omega * c) / a**2)
    amp, p0, p1 = 1.2, 20000.0, 8000.0 * np.exp(0.7j)
    beta = (amp * np.sin(k * length) - p1 / (ea * k)) / np.cos(k * length)
    f0 = -ea * k * beta
    u_l = amp * np.cos(k * length) + beta * np.sin(k * length)
    t = np.arange(n) * period / n
    e = np.exp(1j * omega * t)
    surface_load = well.buoyant_weight() + p0 + np.real(f0 * e)
    pump_pos = -p0 * length / ea + np.real(u_l * e)
    return well, t, np.real(amp * e), surface_load, pump_pos, p0 + np.real(p1 * e)


@pytest.mark.parametrize("nu", [0.0, 0.3])
def test_fourier_matches_the_closed_form(nu: float) -> None:
    well, _t, s, load, pump_pos, pump_load = harmonic_string(nu)
    res = diagnose_card(card(s, load, spm=8.0, metric=True), well, damping=nu)
    assert res.ok and res.convention == "effective" and res.damping == nu
    got = res.pump_load * 1000.0
    assert np.max(np.abs(got - pump_load)) < 1e-6 * np.ptp(pump_load)
    # Positions are given from the plunger's lowest point.
    want = pump_pos - pump_pos.min()
    assert np.max(np.abs(res.pump_position - want)) < 1e-6 * np.ptp(want)


@pytest.mark.parametrize("nu", [0.0, 0.3])
def test_finite_differences_converge_at_second_order(nu: float) -> None:
    well, _t, s, load, _pos, pump_load = harmonic_string(nu)
    strings = StringArrays.of([well])
    dyn = load - well.buoyant_weight()
    errors = []
    for refine in (1, 2, 4, 8):
        _p, ten = fd_diagnostic(s, dyn, 7.5, strings, nu, refine=refine, courant=0.5)
        errors.append(np.max(np.abs(ten[0, -1] - pump_load)) / np.ptp(pump_load))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 1.8) & (orders < 2.2)), (errors, orders)
    assert errors[-1] < 2e-6


def test_fourier_and_finite_differences_agree_on_tapered_cards() -> None:
    well = three_tapers()
    s = surface_motion()
    pump = PumpModel(fluid_load=20000.0, fillage=np.array([1.0, 0.6, 0.8]),
                     intake_ratio=np.array([0.01, 0.01, 0.3]), transfer=0.05)
    pred = predict_surface(well, np.repeat(s[None], 3, 0), 7.5, pump, nu=0.1, tol=1e-6)
    cards = [card(s, pred.surface_load[i] + well.buoyant_weight(), 8.0, f"c{i}")
             for i in range(3)]
    for nu in (0.0, 0.1):
        four = diagnose_cards(cards, well, damping=nu)
        fd = diagnose_cards(cards, well, damping=nu, method="fd")
        for a, b in zip(four, fd, strict=True):
            assert a.ok and b.ok and b.method == "fd" and b.harmonics is None
            span = np.ptp(a.load, axis=1)
            worst = np.max(np.abs(a.load - b.load), axis=1) / span
            assert np.all(worst < 1e-3), worst


def test_predict_in_frequency_domain_inverts_the_diagnostic() -> None:
    well = three_tapers()
    strings = StringArrays.of([well])
    s = surface_motion()
    t = np.arange(200) / 200
    pump_load = 15000 + 6000 * np.tanh(5 * np.sin(2 * np.pi * t))
    surface, plunger = fourier_predict(s, pump_load, 7.5, strings, 0.05)
    pos, ten = fourier_diagnostic(s, surface, 7.5, strings, 0.05)
    assert np.max(np.abs(ten[0, -1] - pump_load)) < 1e-8 * np.ptp(pump_load)
    assert np.max(np.abs(pos[0, -1] - plunger[0])) < 1e-10


def test_reverse_time_order_is_detected_and_used_right() -> None:
    well = three_tapers()
    s = surface_motion()
    pump = PumpModel(fluid_load=20000.0, fillage=0.7, transfer=0.05)
    pred = predict_surface(well, s, 7.5, pump, nu=0.1, tol=1e-6)
    load = pred.surface_load[0] + well.buoyant_weight()
    forward = diagnose_card(card(s, load, 8.0), well)
    backward = diagnose_card(card(s[::-1], load[::-1], 8.0), well)
    assert not forward.reversed and backward.reversed
    assert any("reverse time order" in n for n in backward.notes)
    # Given back in the file's order: the same samples, reversed.
    assert np.allclose(backward.pump_load, forward.pump_load[::-1], atol=1e-9)
    assert backward.pump.fillage == pytest.approx(forward.pump.fillage)


def test_load_conventions_differ_by_the_pressure_on_the_rod() -> None:
    well = three_tapers()
    s = surface_motion()
    load = 30000 + 8000 * np.sin(2 * np.pi * np.arange(200) / 200)
    eff = diagnose_card(card(s, load, 8.0), well)
    true = diagnose_card(card(s, load, 8.0), well, convention="true")
    depth = well.rod_length
    pressure_force = 1000 * 9.80665 * depth * well.tapers[-1].area / LBF
    assert np.allclose(eff.pump_load - true.pump_load, pressure_force)
    assert true.convention == "true"


def test_harmonics_smooth_and_are_bounded_by_the_samples() -> None:
    well = three_tapers()
    s = surface_motion(n=64)
    rng = np.random.default_rng(1)
    load = 30000 + 8000 * np.sin(2 * np.pi * np.arange(64) / 64) + rng.normal(0, 300, 64)
    smooth = diagnose_card(card(s, load, 8.0), well, harmonics=5)
    spectrum = np.abs(np.fft.rfft(smooth.pump_load))
    assert np.all(spectrum[6:] < 1e-9 * spectrum[0])
    capped = diagnose_card(card(s, load, 8.0), well, harmonics=500)
    assert capped.harmonics == 32 and any("resolve 32" in n for n in capped.notes)


def test_batch_equals_single_and_mixes_wells() -> None:
    wells = [three_tapers(), uniform(length=4900 * 0.3048)]
    s = surface_motion()
    cards = [card(s, 30000 + 8000 * np.sin(2 * np.pi * np.arange(200) / 200 + k), 8.0 + k,
                  f"c{k}") for k in range(2)]
    batch = diagnose_cards(cards, wells)
    for c, w, b in zip(cards, wells, batch, strict=True):
        alone = diagnose_card(c, w)
        assert np.allclose(alone.load, b.load) and np.allclose(alone.position, b.position)
        assert b.load.shape == (len(w.tapers), 200)


def test_cards_that_cannot_be_computed_say_why() -> None:
    from pumpid.cards import Card

    well = three_tapers()
    s = surface_motion()
    no_time = Card(position=s / INCH, load=1 + s, position_unit="in", load_unit="lbf")
    no_unit = Card(position=s, load=1 + s).with_spm(8)
    out = diagnose_cards([no_time, no_unit], well)
    assert [r.status for r in out] == ["invalid-input", "invalid-input"]
    assert "--spm" in out[0].reason and "unit is unknown" in out[1].reason
    assert out[0].to_dict()["downhole"] is None
    uneven = Card(position=s / INCH, load=1 + s, position_unit="in", load_unit="lbf",
                  t=np.cumsum(np.linspace(1, 2, s.size)))
    short = Card(position=s[:5] / INCH, load=1 + s[:5], position_unit="in",
                 load_unit="lbf").with_spm(8)
    out = diagnose_cards([uneven, short], well)
    assert "not uniform" in out[0].reason and "at least 8" in out[1].reason
    with pytest.raises(ValueError, match="damping"):
        diagnose_cards([no_time], well, damping=-1)
    with pytest.raises(ValueError, match="Fourier method only"):
        diagnose_cards([no_time], well, method="fd", harmonics=10)


def test_string_transfer_is_unimodular_and_matches_one_rod() -> None:
    from pumpid.rods import string_transfer

    tapered = StringArrays.of([three_tapers()])
    m11, m12, m21, m22 = string_transfer(64, 7.5, tapered, 0.2)
    assert np.allclose(m11 * m22 - m12 * m21, 1.0, atol=1e-9)
    well = uniform()
    t = well.tapers[0]
    m11, m12, m21, m22 = string_transfer(64, 7.5, StringArrays.of([well]), 0.0)
    k = 2 * np.pi * 3 / 7.5 / t.wave_speed
    assert m11[0, 3] == pytest.approx(np.cos(k * t.length))
    assert m12[0, 3] == pytest.approx(-np.sin(k * t.length) / (t.stiffness * k))
    assert m21[0, 3] == pytest.approx(t.stiffness * k * np.sin(k * t.length))


def test_a_multi_stroke_record_is_refused_and_its_strokes_computed() -> None:
    from pumpid.cards import Card, split_strokes

    well = three_tapers()
    s = np.tile(surface_motion(n=100), 3)
    load = 30000 + 8000 * np.sin(2 * np.pi * np.arange(300) / 100)
    record = Card(position=s / INCH, load=load / LBF, position_unit="in", load_unit="lbf",
                  t=np.arange(300) * 0.075, time_source="file")
    refused = diagnose_card(record, well)
    assert refused.status == "invalid-input" and "several strokes" in refused.reason
    strokes = diagnose_cards(split_strokes(record), well)
    assert len(strokes) >= 2 and all(r.ok for r in strokes)
    # One spike in the position does not hide the strokes: counted on the position's
    # robust range (as the card readers count them), not its extremes, which put every
    # other sample below mid-stroke and let the record through as one stroke.
    spiked = s / INCH
    spiked[150] = 10 * spiked.max()
    refused = diagnose_card(record.replace(position=spiked), well)
    assert refused.status == "invalid-input" and "several strokes" in refused.reason


def test_a_loop_that_does_not_close_is_said() -> None:
    well = three_tapers()
    s = surface_motion()[:150]          # three quarters of a stroke
    load = 30000 + 8000 * np.sin(2 * np.pi * np.arange(150) / 200)
    res = diagnose_card(card(s, load, 8.0), well)
    assert res.ok and any("does not close" in n for n in res.notes)
    closed = diagnose_card(card(surface_motion(), 30000 + 8000 * np.sin(
        2 * np.pi * np.arange(200) / 200), 8.0), well)
    assert not any("does not close" in n for n in closed.notes)


def test_a_card_that_breaks_the_solver_fails_alone(monkeypatch) -> None:
    import pumpid.rods.diagnose as diagnose

    well = three_tapers()
    s = surface_motion()
    cards = [card(s, 30000 + 8000 * np.sin(2 * np.pi * np.arange(200) / 200 + k), 8.0,
                  f"c{k}") for k in range(3)]
    real = diagnose.fourier_diagnostic

    calls = {"n": 0}

    def flaky(position, *args, **kwargs):
        # The batch call and the second card alone fail; the others go through.
        calls["n"] += 1
        if np.asarray(position).shape[0] > 1 or calls["n"] == 3:
            raise FloatingPointError("boom")
        return real(position, *args, **kwargs)

    monkeypatch.setattr(diagnose, "fourier_diagnostic", flaky)
    out = diagnose_cards(cards, well)
    assert [r.status for r in out] == ["computed", "failed", "computed"]
    assert "FloatingPointError: boom" in out[1].reason
