"""Dynamometer card readers.

Read load-versus-position cards from the file layouts met in practice, check them, and
record in plain language (``Card.notes``) everything done to the data. This package knows
nothing about the models fitted to the cards, and the rest of pumpid knows nothing about
files.

Public names
------------
Card, CardError, TIME_SOURCES
    The immutable card type, the one error type (a ``ValueError``), allowed time sources.
printable
    Card ids and file names with control characters escaped, for messages and screens.
detect_column_roles, ColumnRoles, ROLE_CONFIDENCE_MIN
    Which column of a headerless table is position and which is load, and how sure.
read_cards, read_card, parse_cards, detect_format, FORMATS
    Readers: delimited tables (CSV/TSV/semicolon/pipe, with or without header), pipe-delimited
    SCADA exports (one card per row), JSON, whitespace tables, sktime ``.ts``.
split_strokes
    Cut a multi-stroke time record into single strokes.
POSITION_UNITS, LOAD_UNITS, TIME_UNITS, convert_position, convert_load,
normalize_position_unit, normalize_load_unit
    Units with exact factors.

Conventions
-----------
* Values are never converted while reading. Units come from the caller
  (``position_unit=``/``load_unit=``, which win), else from the file (column-name
  suffixes such as ``position_in``, ``load (kN)``, ``t_s``; JSON ``units``; SCADA header
  suffixes), else stay ``None`` with a note. ``Card.to_units`` converts explicitly and
  notes it. Time is always in seconds (``t_ms``/``time (ms)`` columns are scaled, noted).
* Time: a time column wins. Otherwise SPM or period (caller first, then the file) rebuilds
  time assuming uniform sampling over ONE stroke: ``t_i = i*T/N`` for the ``N`` distinct
  samples; such cards are marked ``periodic``. Otherwise ``t`` is None.
* Clean-ups (each noted): rows flagged in a closure column (``is_closure_point``) are
  dropped; for cards without a time column, a last sample equal to the first in both
  position and load (relative tolerance 1e-9) is dropped as a duplicated closing point.
  Nothing else is repaired: NaN/inf, fewer than ``min_samples`` samples, time not strictly
  increasing, mismatched lengths, constant load or position, unknown units and unparsable
  numbers raise :class:`CardError` naming the file, the line or field, and the problem.
* SCADA exports: by default each row gives its surface card; downhole lists, when present,
  are kept unchecked in ``metadata["downhole_position"]``/``["downhole_load"]``.
  ``scada_cards="downhole"`` or ``"both"`` returns checked downhole cards (id suffix
  ``/downhole``). SPM wins over ``Stroke Period`` (a note flags a disagreement > 1 %).
* Extra table columns are kept in ``metadata``: constant ones as scalars, varying numeric
  ones as arrays aligned with the kept samples.
"""

from ._errors import CardError
from ._printable import printable
from ._readers import FORMATS, detect_format, parse_cards, read_card, read_cards
from ._roles import ROLE_CONFIDENCE_MIN, ColumnRoles, detect_column_roles
from ._strokes import split_strokes
from ._types import TIME_SOURCES, Card
from ._units import (
    LOAD_UNITS,
    POSITION_UNITS,
    TIME_UNITS,
    convert_load,
    convert_position,
    normalize_load_unit,
    normalize_position_unit,
)

__all__ = [
    "FORMATS",
    "LOAD_UNITS",
    "POSITION_UNITS",
    "ROLE_CONFIDENCE_MIN",
    "TIME_SOURCES",
    "TIME_UNITS",
    "Card",
    "CardError",
    "ColumnRoles",
    "convert_load",
    "convert_position",
    "detect_column_roles",
    "detect_format",
    "normalize_load_unit",
    "normalize_position_unit",
    "parse_cards",
    "printable",
    "read_card",
    "read_cards",
    "split_strokes",
]
