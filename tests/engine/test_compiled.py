"""The compiled cache: which of the main job's functions a fresh install must compile."""

from __future__ import annotations

import json
import os

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
    assert set(compiled.PUMP_JOB) <= names


def test_notice_on_stderr_once_and_not_in_json(tmp_path, monkeypatch, capsys) -> None:
    from ..cli.conftest import write_cards

    card = write_cards(tmp_path / "c.csv", ["A"])
    missing = ["drive.items"]
    monkeypatch.setattr(compiled, "uncached", lambda names=compiled.MAIN_JOB: missing)
    assert main(["fit", str(card), "--json"]) == 0
    out, err = capsys.readouterr()
    json.loads(out)  # stdout stays one JSON document
    assert err.count("compiling the numerical core") == 1
    low, high = compiled.COLD_SECONDS
    assert f"{low}-{high} s on 2 cores" in err


@pytest.mark.parametrize("missing", [[], ["drive.items"]])
def test_notice_only_when_something_is_missing(missing, monkeypatch, capsys) -> None:
    monkeypatch.setattr(compiled, "uncached", lambda names=compiled.MAIN_JOB: missing)
    assert compile_notice() is bool(missing)
    assert ("compiling" in capsys.readouterr().err) is bool(missing)


_MAIN, _PUMP = compiled.MAIN_JOB, compiled.PUMP_JOB


@pytest.mark.parametrize(("argv", "checked"), [
    (["fit", "CARDS"], _MAIN),
    (["batch", "CARDS", "--out", "OUT"], _MAIN),
    (["batch", "CARDS", "--out", "OUT", "--well-file", "WELLS"], _MAIN + _PUMP),
    (["batch", "CARDS", "--out", "OUT", "--well-file", "WELLS", "--pump-only"], _PUMP),
    (["batch", "CARDS", "--out", "OUT", "--well-file", "WELLS", "--no-identify"], _MAIN),
    (["downhole", "CARDS", "--well", "WELLS"], _PUMP),
    (["downhole", "CARDS", "--well", "WELLS", "--no-identify"], ()),
    (["downhole", "CARDS", "--well", "WELLS", "--damping", "0"], ()),
    (["report", "OUT"], ()),
])
def test_notice_checks_what_the_command_compiles(argv, checked, tmp_path, monkeypatch,
                                                 capsys) -> None:
    # Each command is told of the compile it will do: a pump-only run never calls the lumped
    # fit's entry point, so it must not be told of that one's compile on every run (nor a
    # first identification left to compile in silence). The runs below then fail on their
    # missing files; the notice comes before.
    asked: list[tuple[str, ...]] = []

    def uncached(names=compiled.MAIN_JOB):
        asked.append(tuple(names))
        return list(names)

    monkeypatch.setattr(compiled, "uncached", uncached)
    argv = [str(tmp_path / a) if a in ("CARDS", "OUT", "WELLS") else a for a in argv]
    main(argv)
    err = capsys.readouterr().err
    assert asked == ([checked] if checked else [])
    assert ("compiling the numerical core" in err) is bool(checked)
    if checked == _PUMP:
        low, high = compiled.PUMP_COLD_SECONDS
        assert f"about {low}-{high} s" in err


def _times_two(x: float) -> float:
    return 2.0 * x


def _levels_seen(monkeypatch) -> list[int]:
    # numba reads its level (NUMBA_OPT) when a compile starts, in reload_config: record it.
    import numba.core.config as numba_config

    seen: list[int] = []
    reload = numba_config.reload_config

    def recording() -> None:
        reload()
        seen.append(int(numba_config.OPT))

    monkeypatch.setattr(numba_config, "reload_config", recording)
    return seen


@pytest.mark.parametrize("user_level", [None, "1"])
def test_a_listed_function_compiles_at_its_own_level(tmp_path, monkeypatch,
                                                     user_level) -> None:
    monkeypatch.setattr(compiled, "cache_dir", lambda: tmp_path)
    monkeypatch.setitem(compiled.OPT_LEVELS, "test_compiled._times_two", 2)
    if user_level is None:
        monkeypatch.delenv("NUMBA_OPT", raising=False)
    else:
        monkeypatch.setenv("NUMBA_OPT", user_level)
    seen = _levels_seen(monkeypatch)
    listed = compiled.jit(_times_two)
    other = compiled.jit(_add_one)
    assert listed(2.0) == 4.0
    at_listed = list(seen)
    assert other(1.0) == 2.0
    at_other = seen[len(at_listed):]
    if user_level is None:
        assert at_listed and set(at_listed) == {2}
        assert at_other and set(at_other) == {3}
        assert "NUMBA_OPT" not in os.environ
    else:
        # The user's setting applies to everything and is left as it was.
        assert set(at_listed) == set(at_other) == {1}
        assert os.environ["NUMBA_OPT"] == "1"


def test_the_cache_folder_follows_the_levels(monkeypatch) -> None:
    compiled.cache_dir.cache_clear()
    before = compiled.cache_dir()
    monkeypatch.setitem(compiled.OPT_LEVELS, "drive.items", 1)
    compiled.cache_dir.cache_clear()
    try:
        assert compiled.cache_dir() != before
    finally:
        monkeypatch.undo()
        compiled.cache_dir.cache_clear()
    assert compiled.cache_dir() == before


def test_every_listed_level_names_a_compiled_function() -> None:
    # A renamed function would silently fall back to numba's level.
    import pumpid  # noqa: F401  (imports the engine and inference modules)

    assert set(compiled.OPT_LEVELS) <= set(compiled.registered())


def test_copy_into_copies_every_shape_and_strided_views() -> None:
    import numpy as np

    rng = np.random.default_rng(3)
    for shape in [(5,), (3, 4), (2, 3, 4), (0,)]:
        src = rng.standard_normal(shape)
        dst = np.zeros(shape)
        compiled.copy_into(dst, src)
        assert np.array_equal(dst, src)
    # Into one column of a matrix, from a row of another: strided on both sides.
    mat = np.zeros((4, 3))
    rows = rng.standard_normal((3, 4))
    compiled.copy_into(mat[:, 1], rows[2])
    assert np.array_equal(mat[:, 1], rows[2])
    assert not mat[:, [0, 2]].any()


def _compiled_functions(tree) -> list:
    """The functions decorated with ``jit`` (called or not) in a module's tree."""
    import ast

    def is_jit(decorator) -> bool:
        call = decorator.func if isinstance(decorator, ast.Call) else decorator
        return getattr(call, "id", getattr(call, "attr", None)) == "jit"

    return [node for node in ast.walk(tree) if isinstance(node, ast.FunctionDef)
            and any(is_jit(d) for d in node.decorator_list)]


def _slice_assignments(function) -> list[int]:
    """Lines of ``a[...:...] = value`` where value is not a number (an array)."""
    import ast

    lines = []
    for node in ast.walk(function):
        if not isinstance(node, (ast.Assign, ast.AugAssign)):
            continue
        targets = node.targets if isinstance(node, ast.Assign) else [node.target]
        for target in targets:
            if not isinstance(target, ast.Subscript):
                continue
            index = target.slice
            parts = index.elts if isinstance(index, ast.Tuple) else [index]
            number = isinstance(node.value, ast.Constant) or (
                isinstance(node.value, ast.UnaryOp) and isinstance(node.value.operand,
                                                                   ast.Constant))
            if any(isinstance(p, ast.Slice) for p in parts) and not number:
                lines.append(node.lineno)
    return lines


def test_compiled_code_assigns_no_array_to_a_slice() -> None:
    # Each such assignment compiles numba's shape-mismatch message formatter into its
    # function: seconds of a fresh install's first fit. copy_into does the same work.
    import ast
    from pathlib import Path

    package = Path(compiled.__file__).resolve().parents[1]
    found = {}
    n_functions = 0
    for name in compiled.COMPILED_MODULES:
        functions = _compiled_functions(ast.parse((package / name).read_text()))
        n_functions += len(functions)
        lines = [line for fn in functions for line in _slice_assignments(fn)]
        if lines:
            found[name] = lines
    assert n_functions > 50
    assert found == {}
