"""``Revision``: the (incarnation, revision) pair compare-and-set compares, and its text form."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from paramdds import ParamddsError, Revision


@given(st.integers(0, 2**64 - 1), st.integers(0, 2**63 - 1))
def test_the_text_form_reads_back(incarnation: int, revision: int) -> None:
    at = Revision(incarnation, revision)
    text = str(at)
    assert len(text.partition(":")[0]) == 16  # 16 hex digits: sorts and lines up
    assert Revision.parse(text) == at


def test_a_bare_revision_has_no_incarnation() -> None:
    assert Revision.parse(" 12 ") == Revision(0, 12)


@pytest.mark.parametrize("text", ["", ":", "x", "zz:3", "1:x", "-1", f"{2**64:x}:1", f"1:{2**63}", "1:-2"])
def test_anything_else_is_refused(text: str) -> None:
    with pytest.raises(ParamddsError):
        Revision.parse(text)
