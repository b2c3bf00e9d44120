"""Safe output: names from card ids, atomic files, folders replaced whole, reruns said."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pumpid.report import output
from pumpid.report.output import (
    MANIFEST,
    OutputError,
    OutputFolder,
    UniqueNames,
    atomic_write,
    safe_name,
)


@pytest.mark.parametrize(("text", "name"), [
    ("..", "card"), (".", "card"), ("", "card"), ("???", "card"), ("a/b", "a_b"),
    ("a?b", "a_b"), ("..\\..\\evil", "evil"), ("/etc/passwd", "etc_passwd"),
    ("\x1b[31mRED\x1b[0m", "31mRED_0m"), ("CON", "_CON"), ("nul.txt", "_nul.txt"),
    ("é/ü", "e_u"), ("OAK-3@2022-03-01", "OAK-3_2022-03-01"), (".hidden", "hidden"),
    ("well 7", "well_7"),
])
def test_safe_name(text: str, name: str) -> None:
    assert safe_name(text) == name


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=300))
def test_any_id_gives_one_harmless_component(text: str) -> None:
    name = safe_name(text)
    assert 1 <= len(name) <= 80
    assert name not in (".", "..") and not name.startswith(".")
    assert "/" not in name and "\\" not in name and "\x00" not in name
    assert name.isascii() and name.isprintable()
    assert Path(name).name == name and not Path(name).is_absolute()


@settings(max_examples=200, deadline=None)
@given(st.lists(st.text(max_size=20), max_size=30))
def test_claimed_names_are_distinct_ignoring_case(ids: list[str]) -> None:
    names = UniqueNames(reserved=["results.csv"])
    got = [names.claim(i) for i in ids]
    folded = [g.casefold() for g in got]
    assert len(set(folded)) == len(folded)
    assert "results.csv" not in folded
    assert all(g == safe_name(g) for g in got)


def test_collisions_get_stable_distinct_names() -> None:
    names = UniqueNames()
    first, second, third = names.claim("a/b"), names.claim("a?b"), names.claim("A_B")
    assert first == "a_b" and second.startswith("a_b-") and third.startswith("A_B-")
    again = UniqueNames()
    assert [again.claim(x) for x in ("a/b", "a?b", "A_B")] == [first, second, third]


def test_atomic_write_replaces_and_leaves_no_temporary(tmp_path: Path) -> None:
    path = tmp_path / "result.json"
    path.write_text("old")
    atomic_write(path, "new")
    assert path.read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["result.json"]
    assert oct(path.stat().st_mode & 0o777) == oct(0o666 & ~_umask())


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_atomic_write_does_not_follow_a_symlink(tmp_path: Path) -> None:
    outside = tmp_path / "outside.txt"
    outside.write_text("precious")
    folder = tmp_path / "out"
    folder.mkdir()
    (folder / "report.html").symlink_to(outside)
    atomic_write(folder / "report.html", "report")
    assert outside.read_text() == "precious"
    assert not (folder / "report.html").is_symlink()
    assert (folder / "report.html").read_text() == "report"


def test_atomic_write_failure_leaves_old_file_and_no_temporary(tmp_path: Path,
                                                               monkeypatch) -> None:
    path = tmp_path / "card.png"
    path.write_bytes(b"old")

    def refuse(src: str, dst: str) -> None:
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(output.os, "replace", refuse)
    with pytest.raises(OutputError, match=r"card.png: cannot write \(Permission denied\)"):
        atomic_write(path, b"new")
    assert path.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["card.png"]


def test_atomic_write_refuses_a_folder(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="is a folder"):
        atomic_write(tmp_path, "x")


def test_prepare_refuses_a_file_and_a_path_through_a_file(tmp_path: Path) -> None:
    afile = tmp_path / "afile"
    afile.write_text("x")
    with pytest.raises(OutputError, match="exists and is not a folder"):
        OutputFolder(afile).prepare()
    with pytest.raises(OutputError, match="cannot create the output folder"):
        OutputFolder(afile / "sub").prepare()
    assert afile.read_text() == "x"


def test_prepare_clears_leftovers_of_an_interrupted_run(tmp_path: Path) -> None:
    (tmp_path / ".pumpid-partial-abc").mkdir()
    (tmp_path / ".pumpid-partial-abc" / "card.png").write_bytes(b"half")
    (tmp_path / ".pumpid-report.html.x.tmp").write_text("half")
    (tmp_path / "mine.txt").write_text("user file")
    said = OutputFolder(tmp_path).prepare()
    assert said and "removed 2 unfinished output(s)" in said[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine.txt"]


def test_commit_folder_replaces_the_whole_folder(tmp_path: Path) -> None:
    out = OutputFolder(tmp_path)
    out.prepare()
    old = tmp_path / "EX-1A"
    old.mkdir()
    (old / "prediction.png").write_bytes(b"old prediction")
    (old / "report.html").write_text("old")
    with out.staging() as stage:
        (stage / "report.html").write_text("new")
        said = out.commit_folder(stage, "EX-1A")
    assert said == ["replaced EX-1A/ from an earlier run"]
    assert sorted(p.name for p in old.iterdir()) == ["report.html"]
    assert (old / "report.html").read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["EX-1A"]


def test_commit_folder_replaces_a_symlink_not_its_target(tmp_path: Path) -> None:
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "keep.txt").write_text("keep")
    root = tmp_path / "out"
    out = OutputFolder(root)
    out.prepare()
    (root / "card").symlink_to(elsewhere, target_is_directory=True)
    with out.staging() as stage:
        (stage / "result.json").write_text("{}")
        out.commit_folder(stage, "card")
    assert not (root / "card").is_symlink()
    assert sorted(p.name for p in elsewhere.iterdir()) == ["keep.txt"]


def test_commit_folder_refuses_an_unsafe_name(tmp_path: Path) -> None:
    out = OutputFolder(tmp_path)
    with out.staging() as stage, pytest.raises(ValueError, match="not a safe folder name"):
        out.commit_folder(stage, "..")
    assert [p.name for p in tmp_path.iterdir()] == []


def test_staging_is_removed_when_the_block_fails(tmp_path: Path) -> None:
    out = OutputFolder(tmp_path)
    with pytest.raises(RuntimeError), out.staging() as stage:
        (stage / "half.png").write_bytes(b"x")
        raise RuntimeError("interrupted")
    assert list(tmp_path.iterdir()) == []


def test_commit_files_removes_only_stale_files_of_an_earlier_run(tmp_path: Path) -> None:
    out = OutputFolder(tmp_path)
    out.prepare()
    with out.staging() as stage:
        for name in ("report.html", "card.png", "prediction.png"):
            (stage / name).write_text(f"first {name}")
        assert out.commit_files(stage) == []
    (tmp_path / "notes.txt").write_text("the user's")
    with out.staging() as stage:
        for name in ("report.html", "card.png"):
            (stage / name).write_text(f"second {name}")
        said = out.commit_files(stage)
    assert said[0] == f"replaced card.png, report.html from an earlier run in {tmp_path}"
    assert said[1].startswith("removed prediction.png (written there by an earlier run")
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        MANIFEST, "card.png", "notes.txt", "report.html"]
    assert (tmp_path / "report.html").read_text() == "second report.html"
