"""The readout's status codes are in the user docs (issue 44, item 10): a table in docs/usage.md
and in docs/attach.md that gives every code the recorder, ``attach`` and the Gym environment use,
with its name, and no other."""

import re
from pathlib import Path

import pytest

from piezotip.cosim import attach
from piezotip.cosim.rows import STATUS_CODES

DOCS = Path(__file__).resolve().parents[1] / "docs"
#: A status table's row: | code | `name` | ...
ROW = re.compile(r"^\| (-?\d+) \| `([a-z_]+)` \|", re.MULTILINE)


@pytest.mark.parametrize("page", ["usage.md", "attach.md"])
def test_the_docs_table_the_status_codes_as_the_code_numbers_them(page):
    documented = {int(code): name for code, name in ROW.findall((DOCS / page).read_text())}
    assert documented == dict(enumerate(STATUS_CODES)), f"docs/{page}'s status table is not cosim/rows.py's STATUS_CODES"
    assert documented == {code: name for name, code in attach.STATUS_CODES.items()}  # attach's sensor, the same numbers
