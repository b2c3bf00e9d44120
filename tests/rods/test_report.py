"""``pumpid downhole --out``: report.html, one self-contained page per run."""

from __future__ import annotations

import re
from pathlib import Path

from pumpid.cli.main import main

from .test_cli_downhole import SPM, WELL, surface, write_cards, write_well  # noqa: F401

EVIL = "W<script>alert(1)</script>"


def test_report_page_per_run(tmp_path: Path, surface, capsys) -> None:  # noqa: F811
    # a card of a well the file does not describe, named to break unescaped HTML
    doc = {"units": {"length": "ft", "diameter": "in"},
           "wells": {"W-1": WELL["wells"]["W-1"], "W-2": WELL["wells"]["W-1"]}}
    cards = write_cards(tmp_path / "cards.csv", surface, ids=("W-1", EVIL))
    out = tmp_path / "out"
    main(["downhole", str(cards), "--well", str(write_well(tmp_path / "w.json", doc)),
          "--spm", str(SPM), "--out", str(out)])
    capsys.readouterr()
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "<script>" not in page and "W&lt;script&gt;alert(1)&lt;/script&gt;" in page
    # self-contained: the one figure is embedded, nothing is fetched
    assert len(re.findall(r'<img src="data:image/png;base64,', page)) == 1
    assert not re.search(r'(src|href)="(?!data:|#)', page)
    # the computed card: its quantities with units; the other: why not
    assert "pump fillage" in page and "fraction" in page and "lbf" in page and "bbl/d" in page
    assert "invalid-input" in page and "no well" in page
    assert "Notes" in page


def test_report_of_one_card(tmp_path: Path, surface, capsys) -> None:  # noqa: F811
    cards = write_cards(tmp_path / "cards.csv", surface)
    out = tmp_path / "one"
    assert main(["downhole", str(cards), "--well", str(write_well(tmp_path / "w.json")),
                 "--spm", str(SPM), "--card", "card1", "--out", str(out)]) == 0
    capsys.readouterr()
    page = (out / "report.html").read_text(encoding="utf-8")
    assert page.count('id="card-') == 1 and "card1" in page
