"""The compiled cache: which of the main job's functions a fresh install must compile."""

from __future__ import annotations

import json

import pytest

from pumpid.cli import main
from pumpid.cli.common import compile_notice
from pumpid.engine import compiled


def _add_one(x: float) -> float:
    return x + 1.0


def test_uncached_until_compiled(tmp_path, monkeypatch) -> None:
    # A private cache folder: the function below is compiled there from nothing.
    monkeypatch.setattr(compiled, "cache_dir", lambda: tmp_path)
    fn = compiled.jit(_add_one)
    name = "test_compiled._add_one"
    assert compiled.uncached((name,)) == [name]
    assert fn(1.0) == 2.0
    assert compiled.uncached((name,)) == []
    # An unknown name (a module not imported) is not announced.
    assert compiled.uncached(("nowhere.nothing",)) == []


def test_main_job_functions_are_registered() -> None:
    # Every name the notice checks is a compiled function of an imported module: a renamed
    # function would silently drop out of the check.
    import pumpid  # noqa: F401  (imports the engine and inference modules)

    names = set(compiled.registered())
    assert set(compiled.MAIN_JOB) <= names


def test_notice_on_stderr_once_and_not_in_json(tmp_path, monkeypatch, capsys) -> None:
    from ..cli.conftest import write_cards

    card = write_cards(tmp_path / "c.csv", ["A"])
    missing = ["drive.items"]
    monkeypatch.setattr(compiled, "uncached", lambda names=compiled.MAIN_JOB: missing)
    assert main(["fit", str(card), "--json"]) == 0
    out, err = capsys.readouterr()
    json.loads(out)  # stdout stays one JSON document
    assert err.count("compiling the numerical core") == 1
    low, high = compiled.COLD_MINUTES
    assert f"{low}-{high} minutes" in err


@pytest.mark.parametrize("missing", [[], ["drive.items"]])
def test_notice_only_when_something_is_missing(missing, monkeypatch, capsys) -> None:
    monkeypatch.setattr(compiled, "uncached", lambda names=compiled.MAIN_JOB: missing)
    assert compile_notice() is bool(missing)
    assert ("compiling" in capsys.readouterr().err) is bool(missing)
