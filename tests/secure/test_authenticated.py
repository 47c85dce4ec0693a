"""Secure mode records who wrote: the certificate subject, verified against the writer's GUID.

Pure checks of :func:`paramdds.secure.authenticated.subject_of` (no DDS), then real secure
processes: two clients with different certificates, one claiming another's name.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

from paramdds.secure.authenticated import adjusted_prefix, load_ca, subject_of

from .conftest import SecureSystem

TAIL = bytes(range(10))  # the GUID's last 10 bytes: any (a hash of the candidate GUID, the entity)


def _cert(keystore: Path, name: str) -> str:
    return (keystore / "identities" / name / "cert.pem").read_text()


def _key_of(keystore: Path, name: str) -> bytes:
    """The GUID DDS Security gives a participant of identity ``name`` (its first 6 bytes)."""
    from cryptography import x509

    cert = x509.load_pem_x509_certificate(_cert(keystore, name).encode())
    return adjusted_prefix(cert.subject.public_bytes()) + TAIL


def test_a_certificate_names_the_participant_whose_guid_derives_from_it(keystore: Path) -> None:
    ca = load_ca((keystore / "ca" / "identity_ca.pem").read_bytes())
    assert subject_of(_cert(keystore, "op1"), _key_of(keystore, "op1"), ca) == "O=paramdds,CN=op1"
    assert _key_of(keystore, "op1")[0] & 0x80  # the flag bit of an adjusted GUID


def test_another_participants_certificate_names_nobody(keystore: Path) -> None:
    ca = load_ca((keystore / "ca" / "identity_ca.pem").read_bytes())
    # mallory (here: viewer) announces op1's certificate: her GUID derives from her own subject
    assert subject_of(_cert(keystore, "op1"), _key_of(keystore, "viewer"), ca) is None


def test_a_certificate_of_another_ca_or_none_names_nobody(keystore: Path, foreign_keystore: Path) -> None:
    ca = load_ca((keystore / "ca" / "identity_ca.pem").read_bytes())
    foreign = _cert(foreign_keystore, "admin")
    assert subject_of(foreign, _key_of(foreign_keystore, "admin"), ca) is None
    assert subject_of("not a certificate", _key_of(keystore, "op1"), ca) is None
    assert subject_of("", _key_of(keystore, "op1"), ca) is None


READ_HISTORY = """
import json, sys
from paramdds.dds.client import ParameterClient
from paramdds.dds.participant import make_participant
from paramdds.secure.identity import load_identity

domain, identity, node = int(sys.argv[1]), sys.argv[2], sys.argv[3]
participant = make_participant(domain, localhost=True, identity=load_identity(identity))
client = ParameterClient(participant, timeout=10)
records = [r.to_json() for r in client.history(node).records]
got = client.get(node, ["robot.mode", "robot.max_velocity"], with_descriptors=True)
last = {r.name: r.last_change.to_json() for r in got.results if r.last_change is not None}
print(json.dumps({"records": records, "last": last}))
client.close()
"""


def _history(system: SecureSystem, identity: str, node: str) -> dict[str, object]:
    done = subprocess.run(
        [str(system.bin / "python"), "-c", READ_HISTORY, str(system.domain), system.identity(identity), node],
        capture_output=True,
        text=True,
        timeout=60,
        env=system.env(),
        check=False,
    )
    assert done.returncode == 0, done.stderr
    found: dict[str, object] = json.loads(done.stdout.splitlines()[-1])
    return found


def test_the_server_records_each_writers_certificate_whatever_it_claims(system: SecureSystem) -> None:
    # op1 claims to be mallory; admin claims nothing (USER@host)
    done = system.run("op1", "--as", "mallory", "set", "robot1", "robot.mode", "auto")
    assert done.returncode == 0, done.stderr
    done = system.run("admin", "set", "robot1", "robot.max_velocity", "2.5")
    assert done.returncode == 0, done.stderr
    done = system.run("op1", "--as", "mallory", "set", "robot1", "robot.wheel_count", "many")
    assert done.returncode != 0  # refused: a string for an integer

    seen = _history(system, "viewer", "robot1")
    records = [r for r in seen["records"] if isinstance(r, dict) and r["via"] != "start"]
    by_name = {(r["name"], r["outcome"]): r for r in records}
    mode = by_name[("robot.mode", "applied")]
    assert (mode["who"], mode["verified"], mode["via"]) == ("O=paramdds,CN=op1", True, "cli")
    assert (mode["old"], mode["new"]) == ("idle", "auto")
    velocity = by_name[("robot.max_velocity", "applied")]
    assert (velocity["who"], velocity["verified"]) == ("O=paramdds,CN=admin", True)
    refused = by_name[("robot.wheel_count", "refused")]
    assert (refused["who"], refused["verified"]) == ("O=paramdds,CN=op1", True)
    assert not any(r["who"] == "mallory" for r in records)
    # the blame a get with descriptors carries (what describe shows): the same subjects
    last = seen["last"]
    assert isinstance(last, dict)
    assert (last["robot.mode"]["who"], last["robot.mode"]["verified"]) == ("O=paramdds,CN=op1", True)
    assert last["robot.max_velocity"]["who"] == "O=paramdds,CN=admin"


FORGED_SET = """
import shutil, sys, tempfile
from pathlib import Path
from paramdds.dds.client import ParameterClient
from paramdds.dds.participant import close_participant, make_participant
from paramdds.secure.identity import load_identity

domain, own, other = int(sys.argv[1]), load_identity(sys.argv[2]), Path(sys.argv[3])
announced = Path(tempfile.mkdtemp())
shutil.copy(other / "cert.pem", announced / "cert.pem")


class Forged:  # authenticates as its own identity, announces another's certificate
    path, name, role, nodes = announced, own.name, own.role, own.nodes

    def security_config(self, domain_id):
        return own.security_config(domain_id)


participant = make_participant(domain, localhost=True, identity=Forged())
client = ParameterClient(participant, timeout=10, as_="mallory")
print(client.set("robot1", {"robot.name": "forged"}).successful)
client.close()
close_participant(participant)
"""


def test_a_participant_announcing_another_certificate_is_recorded_by_its_claim(system: SecureSystem) -> None:
    done = subprocess.run(
        [str(system.bin / "python"), "-c", FORGED_SET, str(system.domain), system.identity("op1"),
         system.identity("admin")],
        capture_output=True, text=True, timeout=60, env=system.env(), check=False,
    )  # fmt: skip
    assert done.returncode == 0 and done.stdout.split() == ["True"], done.stderr
    records = _history(system, "viewer", "robot1")["records"]
    assert isinstance(records, list)
    (forged,) = [r for r in records if r["name"] == "robot.name" and r["new"] == "forged"]
    assert (forged["who"], forged["verified"]) == ("mallory", False)  # neither admin nor verified
