"""Dynamometer card readers.

Read load-versus-position cards from the file layouts met in practice, check them, and
record in plain language everything done to the data (``Card.notes``) and everything that
looks wrong but was not refused (``Card.warnings``). This package knows nothing about the
models fitted to the cards, and the rest of pumpid knows nothing about files.

Public names
------------
Card, CardError, TIME_SOURCES
    The immutable card type, the one error type (a ``ValueError``), allowed time sources.
read_cards, read_card, parse_cards, detect_format, FORMATS
    Readers: delimited tables (CSV/TSV/semicolon/pipe, with or without header), pipe-delimited
    SCADA exports (one card per row), JSON, whitespace tables, sktime ``.ts``. They raise
    the first problem, of the file or of any one card.
read_cards_and_errors, parse_cards_and_errors, CardsRead
    The same readers, each card on its own: ``.cards`` are the cards that passed their
    checks and ``.errors`` one :class:`CardError` per card that did not (with its
    ``card_id``, file, line and field), so a broken card never costs its neighbours; only a
    problem of the whole file (unreadable, no position column, broken JSON structure ...) is
    raised. In JSON, a bare value that is not JSON (``nan``, ``1.2.3``, ``abc``) spoils only
    the card it is in (named by line and key path); NaN and Infinity literals are read and
    refused by the card's checks. Dates and times given as ``t`` are refused (never read as
    epoch counts).
detect_column_roles, ColumnRoles, ROLE_CONFIDENCE_MIN
    Which column of a headerless table is position and which is load, and how sure.
printable
    Card ids and file names with control characters escaped, for messages and screens.
split_strokes
    Cut a multi-stroke time record into single strokes.
POSITION_UNITS, LOAD_UNITS, TIME_UNITS, convert_position, convert_load,
normalize_position_unit, normalize_load_unit
    Units with exact factors.

Conventions
-----------
* Values are never converted while reading. Units come from the caller
  (``position_unit=``/``load_unit=``, which win), else from the file (column-name
  suffixes such as ``position_in``, ``load (kN)``, ``t_s``; JSON ``units``; SCADA field
  suffixes, or the export's summary fields, see below), else stay ``None``, said once per
  file in the first card's notes. ``Card.to_units`` converts explicitly and notes it. Time
  is always in seconds (``t_ms``/``time (ms)`` columns are scaled, noted).
* Text: a byte-order mark (UTF-8, UTF-16, UTF-32) or the zero-byte pattern of UTF-16/UTF-32
  decides the encoding, else UTF-8, else Latin-1 (noted); ``encoding=`` wins over all that.
* Headerless tables: the position and load columns are recognised from their shapes
  (:func:`detect_column_roles`: the position rises once to a single maximum and back per
  stroke, smooth and sinusoid-like against sample index; the load is rougher and forms with
  it a loop of positive work; monotone columns such as an angle, an index or time, constant
  and few-valued columns are neither). The choice and its confidence go to a note and to
  ``metadata["column_roles"]`` (``position``, ``load``, ``confidence``, ``words``,
  ``method``, ``other``); tables with a header record there how the header named them.
  Below ``ROLE_CONFIDENCE_MIN`` (0.9) the read is refused and the message asks for
  ``columns=`` (command line ``--columns position=1,load=0``); below 0.95 the card gets a
  warning. Given ``columns=`` always win.
* Time: a time column wins; in a table it may hold ISO 8601 date/time stamps, one a sample
  (seconds from the card's first stamp, which becomes its card time; a time of day runs on
  past midnight; one stamp through a whole card is its card time only). Otherwise SPM or
  period (caller first, then the file) rebuilds time assuming uniform sampling over ONE
  stroke: ``t_i = i*T/N`` for the ``N`` distinct samples; such cards are marked
  ``periodic``. A card whose position rises through
  mid-stroke (below 35 % then above 65 % of its range) twice or more holds several strokes:
  each gets the period, ``t_i = i*T/S`` with ``S`` the median number of samples between two
  rises, the card is a record (not ``periodic``) and a warning says so
  (:func:`strokes_seen`, :func:`time_from_rate`). Otherwise ``t`` is None.
* Card time (when the card was recorded): a field named ``timestamp``, ``datetime``,
  ``card_time``, ``time`` or ``date`` (any case; a SCADA field, a constant table column, a
  JSON key) holding ISO 8601 text is also given as ``metadata["time"]``, an aware UTC
  ``datetime`` (a time without a zone is taken as UTC, noted); other text is noted and left.
* Clean-ups (each noted): rows flagged in a closure column (``is_closure_point``) are
  dropped; for cards without a time column, a last sample equal to the first in both
  position and load (relative tolerance 1e-9) is dropped as a duplicated closing point;
  samples at a card's end (or start) that repeat one point exactly in both position and
  load are dropped as padding: at least 3 of them where the card jumps to that point (a
  fill of zeros), at least 5 % of the card where it runs on into it (a record filled with
  its last sample, whose first repeat is kept); a moving rod never holds both to every
  digit that long, an export that fills a fixed-length record does.
  Nothing else is repaired: NaN/inf, fewer than ``min_samples`` samples, time not strictly
  increasing, mismatched lengths, constant load or position (or varying only in the 12th
  significant digit, at any scale), unknown units, unparsable or complex numbers, a SPM or
  period that is not a positive number, and the rows of one card id in two separate blocks
  of a table (say A, B, A: refused rather than merged, naming both blocks' lines) raise
  :class:`CardError` naming the file, the line or field, and the problem. No other
  exception (nor a numpy warning) escapes the readers; messages show control characters
  escaped (:func:`printable`), while ``Card.card_id`` keeps the raw id.
* SCADA exports: by default each row gives its surface card; downhole lists, when present,
  are kept unchecked in ``metadata["downhole_position"]``/``["downhole_load"]``.
  ``scada_cards="downhole"`` or ``"both"`` returns checked downhole cards (id suffix
  ``/downhole``). SPM wins over ``Stroke Period`` (a note flags a disagreement > 1 %).
  Without units in the list fields' names, a ``Stroke Length (in)`` field equal (within
  2 %) to the stroke or top of the row's positions gives the position unit, a ``Peak
  Load (lbf)`` / ``Min Load (lbf)`` field equal to the row's largest / smallest load gives
  the load unit, and a ``Units`` field saying English gives inches and pounds-force; each
  inference is checked on that row and noted.
* Extra table columns are kept in ``metadata``: constant ones as scalars, varying numeric
  ones as arrays aligned with the kept samples.

Plausibility warnings
---------------------
A polished-rod card whose magnitudes are unlikely gets a warning (``Card.warnings``) naming
the card and the value with its unit; nothing is changed or refused. With an unknown unit,
a value is flagged only when it is implausible in every unit it could be in.

* stroke length (range of the position) above 15 m (590 in) or below 0.01 m (0.4 in);
* a position more than 30 m from zero;
* largest load magnitude above 450 kN (about 100,000 lbf) or below 10 N (about 2 lbf);
* load range below 1 % of the mean load;
* position and load that look swapped: the detector above, run on the two, prefers the
  other order with confidence 0.95 or more (not checked when the roles were just detected);
* a loop that turns the wrong way for time order (negative work of more than a tenth of
  the rectangle the stroke and the load's swing span);
* consecutive samples that repeat one (position, load) point exactly, at least 3 and 5 % of
  the card (a frozen sensor or a stopped unit; at the card's end or start such a run is
  padding and is dropped);
* a record of several strokes without time, given a stroke rate (timed per stroke, see
  above).
"""

from ._common import one_period, repeats_first, stroke_period, with_record_warnings
from ._errors import CardError
from ._plausible import (
    leading_padding,
    loop_work,
    open_stroke,
    padding_dropped,
    stroke_rate_warning,
    trailing_padding,
)
from ._printable import printable
from ._readers import (
    FORMATS,
    CardsRead,
    detect_format,
    parse_cards,
    parse_cards_and_errors,
    read_card,
    read_cards,
    read_cards_and_errors,
)
from ._rises import record_stroke, several_strokes, strokes_seen, time_from_rate
from ._roles import ROLE_CONFIDENCE_MIN, ColumnRoles, detect_column_roles
from ._strokes import split_strokes
from ._text import interpret_name
from ._types import TIME_SOURCES, Card
from ._units import (
    BARREL_M3,
    LOAD_UNITS,
    POSITION_UNITS,
    PSI_PA,
    TIME_UNITS,
    convert_load,
    convert_position,
    normalize_load_unit,
    normalize_position_unit,
    normalize_time_unit,
)

__all__ = [
    "BARREL_M3",
    "FORMATS",
    "LOAD_UNITS",
    "POSITION_UNITS",
    "PSI_PA",
    "ROLE_CONFIDENCE_MIN",
    "TIME_SOURCES",
    "TIME_UNITS",
    "Card",
    "CardError",
    "CardsRead",
    "ColumnRoles",
    "convert_load",
    "convert_position",
    "detect_column_roles",
    "detect_format",
    "interpret_name",
    "leading_padding",
    "loop_work",
    "normalize_load_unit",
    "normalize_position_unit",
    "normalize_time_unit",
    "one_period",
    "open_stroke",
    "padding_dropped",
    "parse_cards",
    "parse_cards_and_errors",
    "printable",
    "read_card",
    "read_cards",
    "read_cards_and_errors",
    "record_stroke",
    "repeats_first",
    "several_strokes",
    "split_strokes",
    "stroke_period",
    "stroke_rate_warning",
    "strokes_seen",
    "time_from_rate",
    "trailing_padding",
    "with_record_warnings",
]
