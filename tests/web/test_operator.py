"""Who a console write is made as, the token file, and the JSON of blame and history (no DDS, no HTTP)."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from paramdds.core.history import HistoryRecord
from paramdds.core.results import LastChange
from paramdds.core.values import ParameterValue
from paramdds.exits import UsageError
from paramdds.listen import Token, matching, parse_tokens
from paramdds.web.model import history_row, parameter_row
from paramdds.web.operator import claimed_name, operator
from paramdds.web.serve import options_from
from paramdds.web.status import WebError

ALICE = "alice-token-0123456789"
BOB = "bob-token-0123456789ab"


def test_a_token_file_holds_one_token_or_one_named_token_per_line() -> None:
    assert parse_tokens("just-one-token-of-length\n") == (Token("just-one-token-of-length"),)
    text = f"# operators\nalice {ALICE}\n\nbob   {BOB}\n"
    assert parse_tokens(text) == (Token(ALICE, "alice"), Token(BOB, "bob"))


@pytest.mark.parametrize(
    ("text", "why"),
    [
        ("", "no token"),
        ("# only a comment\n", "no token"),
        ("short\n", "line 1: a token must be one word of at least 16"),
        (f"alice {ALICE} extra\n", "line 1: expected TOKEN or NAME TOKEN, got 3 words"),
        (f"alice {ALICE}\nbob {ALICE}\n", "line 2: this token is given twice"),
    ],
)
def test_a_token_file_that_is_not_one_is_refused_with_its_line(text: str, why: str) -> None:
    with pytest.raises(ValueError, match=why):
        parse_tokens(text)


def test_the_console_reads_named_tokens_and_refuses_a_bad_file(tmp_path: Path) -> None:
    path = tmp_path / "tokens"
    path.write_text(f"alice {ALICE}\n")
    args = argparse.Namespace(token_file=str(path), read_only=False, domain=1, timeout=5.0)
    assert options_from(args, "127.0.0.1").tokens == (Token(ALICE, "alice"),)
    path.write_text(f"alice {ALICE} {BOB}\n")
    with pytest.raises(UsageError, match=r"--token-file .*tokens: line 1: expected TOKEN or NAME TOKEN"):
        options_from(args, "127.0.0.1")


def test_the_token_given_is_found_among_them() -> None:
    tokens = parse_tokens(f"alice {ALICE}\nbob {BOB}\n")
    assert matching(tokens, BOB) == Token(BOB, "bob")
    assert matching(tokens, "") is None and matching(tokens, ALICE[:-1]) is None


def test_who_a_write_is_made_as() -> None:
    named, unnamed = Token(ALICE, "alice"), Token(ALICE)
    assert operator(named, "mallory", "web@console") == "alice"  # the token's name wins over the claim
    assert operator(unnamed, "carol", "web@console") == "carol"
    assert operator(None, "carol", "web@console") == "carol"
    assert operator(None, "", "web@console") == "web@console"  # nobody said: the console's own identity


def test_the_name_a_page_gives() -> None:
    assert claimed_name({}) == "" and claimed_name({"as": None}) == ""
    assert claimed_name({"as": "  carol  "}) == "carol"
    for bad in (5, ["carol"], "x" * 101, "car\nol"):
        with pytest.raises(WebError, match="'as' must be a name"):
            claimed_name({"as": bad})


def test_a_row_carries_its_last_change_and_a_record_its_types() -> None:
    last = LastChange("carol", False, "web", 1_764_380_000_000_000_000, 7)
    row = parameter_row("gain", ParameterValue.from_python(2.0), None, last)
    assert row["last_change"] == {
        "who": "carol",
        "verified": False,
        "via": "web",
        "time": "2025-11-29T01:33:20.000000Z",
        "revision": 7,
    }
    assert parameter_row("gain", ParameterValue.from_python(2.0), None)["last_change"] is None
    record = HistoryRecord(
        3, "arm", "gain", 7, last.time_ns, "carol", False, "web",
        ParameterValue.from_python(1.0), ParameterValue.from_python(2.0),
    )  # fmt: skip
    shown = history_row(record)
    assert shown["old"] == 1.0 and shown["new"] == 2.0 and shown["outcome"] == "applied"
    assert shown["old_type"] == shown["new_type"] == "double" and shown["seq"] == 3 and shown["code"] is None
    refused = HistoryRecord(
        4, "arm", "gain", 7, last.time_ns, "carol", False, "web",
        ParameterValue.from_python(2.0), None, applied=False, code="READ_ONLY", reason="read-only",
    )  # fmt: skip
    shown = history_row(refused)
    assert shown["outcome"] == "refused" and shown["new_type"] is None and shown["code"] == "READ_ONLY"
