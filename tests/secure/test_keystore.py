"""The keystore and identities, without DDS; and the clear error on a library without security."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from paramdds.errors import ErrorCode, ParamddsError
from paramdds.secure.identity import check_domain, identity_from_env, load_identity
from paramdds.secure.keystore import KeystoreError, add_identity, init_keystore

from ..conftest import TEST_URI


def test_keys_are_private_and_documents_signed(keystore: Path) -> None:
    for key in [*keystore.glob("ca/*.key.pem"), *keystore.glob("identities/*/key.pem")]:
        assert stat.S_IMODE(key.stat().st_mode) == 0o600, key
    assert stat.S_IMODE((keystore / "ca").stat().st_mode) == 0o700
    for doc in ("governance.p7s", "identities/op1/permissions.p7s"):
        text = (keystore / doc).read_text()
        assert "pkcs7-signature" in text and "multipart/signed" in text


def test_permissions_grant_the_role_topics_in_the_node_globs(keystore: Path) -> None:
    viewer = (keystore / "identities" / "viewer" / "permissions.xml").read_text()
    publish = viewer.split("<publish>")[1].split("</publish>")[0]
    assert "GetParametersRequest" in publish and "SetParametersRequest" not in publish
    assert "<partition>*</partition>" in publish
    operator = (keystore / "identities" / "op1" / "permissions.xml").read_text()
    assert "<partition>robot1*</partition>" in operator and "<default>DENY</default>" in operator
    assert "<max>230</max>" in (keystore / "governance.xml").read_text()


def test_keystore_input_errors_say_what_to_fix(tmp_path: Path, keystore: Path) -> None:
    with pytest.raises(KeystoreError, match="not a keystore"):
        add_identity(tmp_path, "x", "viewer", ["*"])
    with pytest.raises(KeystoreError, match="already holds a keystore"):
        init_keystore(keystore)
    with pytest.raises(KeystoreError, match="role 'root'"):
        add_identity(keystore, "x", "root", ["*"])
    with pytest.raises(KeystoreError, match="node glob"):
        add_identity(keystore, "x", "viewer", ["robot 1"])
    with pytest.raises(KeystoreError, match="at least one"):
        add_identity(keystore, "x", "viewer", [])


def test_identity_loading(keystore: Path, tmp_path: Path) -> None:
    op1 = load_identity(keystore / "identities" / "op1")
    assert (op1.name, op1.role, op1.nodes) == ("op1", "operator", ("robot1*",))
    assert op1.covers("robot1b") and not op1.covers("robot2")
    assert f"file:{op1.path}/key.pem" in op1.security_xml()
    assert identity_from_env(None, {}) is None
    assert identity_from_env(None, {"PARAMDDS_IDENTITY": str(op1.path)}) == op1
    with pytest.raises(ParamddsError, match="not a paramdds identity") as info:
        load_identity(tmp_path)
    assert info.value.code is ErrorCode.FILE_FORMAT
    with pytest.raises(ParamddsError, match=r"0\.\.230"):
        check_domain(231)


def test_a_library_without_security_stops_with_how_to_get_one(keystore: Path) -> None:
    """The test environment's PyPI wheel has no DDS Security."""
    paramdds = str(Path(sys.executable).with_name("paramdds"))
    env = dict(os.environ, CYCLONEDDS_URI=TEST_URI, PARAMDDS_DOMAIN="150")
    env.pop("CYCLONEDDS_HOME", None)
    done = subprocess.run(
        [paramdds, "--identity", str(keystore / "identities" / "admin"), "nodes"],
        capture_output=True,
        text=True,
        timeout=30,
        env=env,
        check=False,
    )
    assert done.returncode == 4, done
    assert "secure mode needs Cyclone DDS built with security" in done.stderr
    assert "paramdds keystore install" in done.stderr


def test_the_keystore_verb(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from paramdds.cli import main

    root = tmp_path / "ks"
    assert main(["keystore", "init", str(root)]) == 0
    assert (
        main(["keystore", "add", str(root), "ops", "--role", "operator", "--nodes", "arm*", "--nodes", "leg"])
        == 0
    )
    out = capsys.readouterr().out
    assert f"identity ops (operator, nodes arm* leg): --identity {root}/identities/ops" in out
    assert load_identity(root / "identities" / "ops").nodes == ("arm*", "leg")
    assert main(["keystore", "init", str(root)]) == 2
    assert "already holds a keystore" in capsys.readouterr().err
    assert main(["keystore", "add", str(root), "x", "--role", "root", "--nodes", "*"]) == 2


def test_install_says_what_is_missing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from paramdds.cli import main

    code = main(
        ["keystore", "install", "--source", str(tmp_path / "none.tar.gz"), "--prefix", str(tmp_path / "p")]
    )
    assert code == 4
    assert "none.tar.gz: no such file or directory" in capsys.readouterr().err
