"""``paramdds server --validators MODULE --strict-spec``, and a declared-but-unset parameter on the wire.

Real processes on loopback, real Cyclone DDS (see ``_support``).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ._support import next_domain, run_cli, start_server

MODULE = """\
from paramdds.core.custom_validators import register_validator


def even(value, args):
    return None if value.value % 2 == 0 else "be even"


register_validator("acme_cli::even", even, replace=True)
"""

SPEC = """\
arm:
  k:
    type: int
    default_value: 2
    validation:
      acme_cli::even<>: null
      acme_cli::unknown<>: [1]
"""

UNSET = """\
arm:
  ros__parameters:
    u: !not_set
  paramdds__descriptors:
    u:
      type: integer
      description: set me
"""


@pytest.fixture
def files(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    (tmp_path / "acme_cli_validators.py").write_text(MODULE, encoding="utf-8")
    (tmp_path / "spec.yaml").write_text(SPEC, encoding="utf-8")
    (tmp_path / "unset.yaml").write_text(UNSET, encoding="utf-8")
    monkeypatch.setenv("PYTHONPATH", str(tmp_path))  # the server subprocess imports the module from here
    return tmp_path


@pytest.mark.slow
def test_validators_module_is_enforced_and_an_unknown_one_is_logged_not_enforced(files: Path) -> None:
    domain = next_domain()
    server = start_server(
        domain, "-n", "arm", "--spec", str(files / "spec.yaml"), "--validators", "acme_cli_validators"
    )
    try:
        assert run_cli(domain, "set", "arm", "k=4").returncode == 0
        refused = run_cli(domain, "set", "arm", "k=5")
        assert refused.returncode == 1 and "must be even" in refused.stdout + refused.stderr
        described = json.loads(run_cli(domain, "describe", "arm", "k", "-o", "json").stdout)["k"]
        # the spec's own text only, as generate_parameter_library; the server's log says it
        assert described["additional_constraints"] == ""
        assert [v["kind"] for v in described["validators"]] == ["acme_cli::even", "acme_cli::unknown"]
    finally:
        assert server.stop() == 0
    assert "acme_cli::unknown" in server.stderr() and "NOT be enforced" in server.stderr()


@pytest.mark.slow
def test_strict_spec_and_a_bad_validators_module_exit_2_before_serving(files: Path) -> None:
    domain = next_domain()
    strict = run_cli(
        domain,
        "server",
        "-n",
        "arm",
        "--spec",
        str(files / "spec.yaml"),
        "--validators",
        "acme_cli_validators",
        "--strict-spec",
    )
    assert (
        strict.returncode == 2 and "acme_cli::unknown" in strict.stderr and "not registered" in strict.stderr
    )
    missing = run_cli(domain, "server", "-n", "arm", "--validators", "no_such_module_here")
    assert missing.returncode == 2 and "--validators no_such_module_here: cannot import it" in missing.stderr


@pytest.mark.slow
def test_a_declared_but_unset_parameter_travels_the_wire_and_can_be_set(files: Path) -> None:
    domain = next_domain()
    server = start_server(domain, "-n", "arm", "-p", str(files / "unset.yaml"))
    try:
        described = json.loads(run_cli(domain, "describe", "arm", "u", "-o", "json").stdout)["u"]
        assert described["type"] == "integer" and described["description"] == "set me"
        assert json.loads(run_cli(domain, "list", "arm", "-o", "json").stdout) == ["u"]
        unset = run_cli(domain, "get", "arm", "u", "-o", "json")
        assert unset.returncode == 0 and json.loads(unset.stdout) == {"u": None}  # declared, no value yet
        assert run_cli(domain, "set", "arm", "u=word").returncode == 1  # still an integer parameter
        assert run_cli(domain, "set", "arm", "u=7").returncode == 0
        assert json.loads(run_cli(domain, "get", "arm", "u", "-o", "json").stdout) == {"u": 7}
    finally:
        assert server.stop() == 0
