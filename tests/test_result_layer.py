"""The result package is a lower layer than inference and the profile: it imports neither.

Every import counts, at module level, inside functions and under ``TYPE_CHECKING`` (read
with ``ast``, nothing imported): a deferred import upward is still a cycle between layers.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "pumpid"


def module_of(path: Path) -> str:
    parts = ["pumpid", *path.relative_to(SRC).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported(path: Path) -> set[str]:
    """Every pumpid module ``path`` imports, wherever the import stands."""
    name = module_of(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")
            base = base[: len(base) - (node.level - 1)] if node.level else []
            source = ".".join([*base, *([node.module] if node.module else [])])
            out |= {source, *(f"{source}.{a.name}" for a in node.names)}
    return out


@pytest.mark.parametrize("lower,upper", [
    ("pumpid.result", "pumpid.inference"),
    ("pumpid.result", "pumpid.profile"),
    ("pumpid.inference", "pumpid.profile"),
    ("pumpid.engine", "pumpid.profile"),
    ("pumpid.job", "pumpid.profile"),
])
def test_a_lower_layer_imports_no_upper_one(lower: str, upper: str) -> None:
    paths = [p for p in SRC.rglob("*.py")
             if module_of(p) == lower or module_of(p).startswith(lower + ".")]
    assert paths, f"no modules under {lower}"
    offenders = sorted(f"{module_of(p)} imports {m}" for p in paths for m in imported(p)
                       if m == upper or m.startswith(upper + "."))
    assert offenders == []


def test_a_first_order_scale_has_its_unit() -> None:
    # Driven by the load, a first-order lag's output is in load * s: C turns it into a
    # position and was printed as a bare number ("-"); a Kelvin model's C is a number.
    import numpy as np

    import pumpid

    t = np.linspace(0.0, 20.0, 201)
    f = 10.0 + 3.0 * np.sin(t)
    u = 2.0 * pumpid.simulate(pumpid.FirstOrder(tau=1.5), t, f)
    lag = pumpid.fit(pumpid.FirstOrder, (t, f, u), options=pumpid.FitOptions(scale="free"))
    assert lag.scale_unit() == f"{lag.units.position}/({lag.units.load}*s)"
    assert "C (scale)        2" in lag.report() and lag.scale_unit() in lag.report()
    kelvin = pumpid.fit(pumpid.Kelvin(k0=4.0, m=1.0, c1=0.2, k1=4.0), (t, f, u))
    assert kelvin.scale_unit() == "-"
