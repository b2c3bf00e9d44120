"""``pumpid downhole --out``: report.html, one self-contained page per run."""

from __future__ import annotations

import base64
import io
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


def _figure(page: str) -> tuple[int, int]:
    """Height and width (pixels) of the page's one embedded figure."""
    import matplotlib.image

    data = re.search(r'<img src="data:image/png;base64,([^"]+)"', page)
    assert data is not None
    image = matplotlib.image.imread(io.BytesIO(base64.b64decode(data.group(1))), format="png")
    return image.shape[0], image.shape[1]


def test_report_of_one_card(tmp_path: Path, surface, capsys) -> None:  # noqa: F811
    cards = write_cards(tmp_path / "cards.csv", surface)
    out = tmp_path / "one"
    assert main(["downhole", str(cards), "--well", str(write_well(tmp_path / "w.json")),
                 "--spm", str(SPM), "--card", "card1", "--out", str(out)]) == 0
    capsys.readouterr()
    page = (out / "report.html").read_text(encoding="utf-8")
    assert page.count('id="card-') == 1 and "card1" in page
    # the identification: its status, the fit's R^2 and residual, the damping and its rule
    assert "identification <b>converged</b>" in page
    assert "surface-load fit R&sup2; 0.99" in page and "residual lag-1 autocorrelation" in page
    assert "identified from the card" in page
    # the quantities with their errors beside the diagnostic card's, and the parameters
    assert "identified &plusmn; standard error" in page and "diagnostic pump card" in page
    assert re.search(r"<td>pump fillage</td><td class=\"num\">0\.(69|70)\d* \u00b1 ", page)
    assert "<th>fitted parameter</th>" in page and "<td>fluid_load</td>" in page
    # the damping's unit in the words of the quantity table beside it (it said "1" there)
    assert re.search(r"<td>damping</td><td class=\"num\">[^<]*</td><td>dimensionless</td>",
                     page)
    assert "<td>1</td>" not in page
    # the figure: measured and fitted surface loads, the residual, both pump cards (2 x 2)
    assert "fitted minus measured load over the stroke" in page
    assert "identified pump card (green) over the diagnostic one" in page
    assert _figure(page) == (840, 1100)
    assert _figure(page) == matplotlib_shape(out / "cards.png")


def matplotlib_shape(path: Path) -> tuple[int, int]:
    import matplotlib.image

    image = matplotlib.image.imread(path)
    return image.shape[0], image.shape[1]


def test_report_without_identification(tmp_path: Path, surface, capsys) -> None:  # noqa: F811
    cards = write_cards(tmp_path / "cards.csv", surface)
    out = tmp_path / "one"
    assert main(["downhole", str(cards), "--well", str(write_well(tmp_path / "w.json")),
                 "--spm", str(SPM), "--card", "card1", "--out", str(out),
                 "--no-identify"]) == 0
    capsys.readouterr()
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "Pump not identified (--no-identify" in page
    assert "identified &plusmn;" not in page and "fitted parameter" not in page
    assert _figure(page) == (420, 1000)  # the surface card beside the pump card



def test_the_all_cards_table_stacks_values_and_errors(tmp_path: Path, surface,  # noqa: F811
                                                      capsys) -> None:
    # At one line a cell, the table ran past the page: displacement and intake pressure
    # went unseen at any window width.
    out = tmp_path / "out"
    main(["downhole", str(write_cards(tmp_path / "cards.csv", surface)), "--well",
          str(write_well(tmp_path / "w.json")), "--spm", str(SPM), "--out", str(out)])
    capsys.readouterr()
    page = (out / "report.html").read_text(encoding="utf-8")
    table = page[page.index("<h2>All cards</h2>"):page.index('<h2 id="card-0">')]
    assert "<br>\u00b1 " in table and "displace&shy;ment [bbl/d]" in table
