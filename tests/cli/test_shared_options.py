"""One fit option set for ``pumpid fit`` and ``pumpid batch``, and one card runner: the
same options give the same answers through both commands."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pytest

import pumpid
from pumpid.cli import main
from pumpid.fleet.store import results_schema, storable_table

EXAMPLE = Path(pumpid.__path__[0]) / "data" / "example_cards.csv"


def _fit_json(capsys: pytest.CaptureFixture[str], *argv: str) -> list[dict]:
    code = main(["fit", str(EXAMPLE), "--json", *argv])
    assert code in (0, 3, 5, 6), capsys.readouterr().err
    return json.loads(capsys.readouterr().out)["cards"]


@pytest.mark.parametrize("argv", [
    ("--model", "msd"),
    ("--model", "auto"),
    ("--model", "kelvin", "--method", "newton-fd", "--observe", "u"),
    ("--model", "kelvin", "--max-nfev", "5"),
])
def test_fit_and_batch_agree_option_for_option(tmp_path: Path, capsys, argv) -> None:
    cards = _fit_json(capsys, *argv)
    out = tmp_path / "run"
    assert main(["batch", str(EXAMPLE), "--out", str(out), "--quiet", *argv]) in (0, 3, 5, 6)
    capsys.readouterr()
    rows = pumpid.read_results(out)
    assert list(rows["status"]) == [c["status"] for c in cards]
    assert list(rows["model"]) == [c["model"] for c in cards]
    for c, (_, row) in zip(cards, rows.iterrows(), strict=True):
        for name, value in (c.get("params") or {}).items():
            if value is None:  # JSON's null for a value not computed (NaN)
                assert pd.isna(row[f"p_{name}"]), name
            else:
                assert row[f"p_{name}"] == pytest.approx(value, rel=1e-9), name


def test_batch_reads_with_an_encoding_and_column_roles(tmp_path: Path, capsys) -> None:
    text = EXAMPLE.read_text(encoding="utf-8").splitlines()
    header = text[0].split(",")
    # Rename the position and load columns to names no reader guesses; --columns says them.
    renamed = [{"position_in": "weg", "load_lbf": "kraft"}.get(h.strip(), h) for h in header]
    assert "weg" in renamed and "kraft" in renamed
    path = tmp_path / "cards.csv"
    path.write_text("\n".join([",".join(renamed), *text[1:]]) + "\n", encoding="utf-16")
    out = tmp_path / "run"
    code = main(["batch", str(path), "--out", str(out), "--quiet", "--encoding", "utf-16",
                 "--columns", "position=weg,load=kraft", "--position-unit", "in",
                 "--load-unit", "lbf"])
    assert code == 0, capsys.readouterr().err
    rows = pumpid.read_results(out)
    assert len(rows) == 2 and set(rows["status"]) <= {"converged", "boundary"}


def test_a_row_key_the_schema_lacks_is_an_error() -> None:
    schema = results_schema(pumpid.Kelvin)
    row = dict.fromkeys(schema.names)
    assert storable_table([row], schema).num_rows == 1
    with pytest.raises(ValueError, match="p_c"):
        storable_table([{**row, "p_c": 1.0}], schema)
    both = results_schema([pumpid.Kelvin, pumpid.MassSpringDamper])
    assert {"p_k0", "p_c", "p_k"} <= set(both.names)
    assert isinstance(both, pa.Schema) and len(set(both.names)) == len(both.names)
