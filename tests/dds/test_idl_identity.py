"""The hand-written wire types in ``paramdds/dds/wire/types.py`` are exactly ``idl/paramdds.idl``.

How the IDL is compiled
-----------------------
We use the IDL compiler that ships inside the ``cyclonedds`` wheel
(``cyclonedds/.libs/idlc``) with the wheel's own Python backend
(``cyclonedds/_idlpy*.so``), so no system package or build step is needed and
the compiler always matches the installed binding.

As shipped in 11.0.1 that ``idlc`` dies with SIGSEGV inside the dynamic loader,
before ``main``. The cause: the wheel's repair step (patchelf) moved the program
headers and ``.dynamic`` into a new first ``PT_LOAD`` segment whose file size
stops short of the end of ``.dynamic``; the tail of ``.dynamic`` lands on the
next page, which the next segment maps read-only, and ``ld.so`` faults writing
``DT_DEBUG`` there. :func:`_runnable_idlc` therefore copies the binary into a
temporary directory and sets the write flag on the load segment(s) covering
``.dynamic`` (a four-byte change per segment in the program header table). The
copy no longer finds the wheel's libraries through its ``$ORIGIN`` rpath, so it
runs with ``LD_LIBRARY_PATH`` pointing at ``cyclonedds.libs``. If a later wheel
ships a working ``idlc``, it is used as is.

The generated Python package is named ``paramdds`` too (the IDL module), so it
is imported in a child interpreter with the output directory first on
``sys.path``; the child prints the XTypes type identifiers (complete and
minimal, CDR-serialized, hex) of every struct it defines. The test compares
them, and the set of type names, with the classes in ``types.py``. A complete
type identifier hashes names, member names, member types, bounds, keys and
extensibility, so editing a member in one place and not the other fails here.
"""

from __future__ import annotations

import json
import os
import shutil
import struct
import subprocess
import sys
from pathlib import Path

import cyclonedds
import pytest
from cyclonedds.idl import IdlStruct

from paramdds.dds.wire import types

REPO = Path(__file__).resolve().parents[2]
IDL_FILE = REPO / "idl" / "paramdds.idl"
WHEEL = Path(cyclonedds.__file__).resolve().parent
WHEEL_LIBS = WHEEL.parent / "cyclonedds.libs"

_PT_LOAD, _PT_DYNAMIC, _PF_W = 1, 2, 2

_CHILD = r"""
import json, sys
sys.path.insert(0, sys.argv[1])
import paramdds
from cyclonedds.idl import IdlStruct
assert paramdds.__file__.startswith(sys.argv[1]), paramdds.__file__
out = {}
for name in dir(paramdds):
    cls = getattr(paramdds, name)
    if isinstance(cls, type) and issubclass(cls, IdlStruct):
        info = cls.__idl__.get_type_info()
        out[cls.__idl_typename__] = [
            info.complete.typeid_with_size.type_id.serialize().hex(),
            info.minimal.typeid_with_size.type_id.serialize().hex(),
        ]
print(json.dumps(out))
"""


def _idlc_env() -> dict[str, str]:
    env = dict(os.environ)
    env["LD_LIBRARY_PATH"] = os.pathsep.join(
        p for p in (str(WHEEL_LIBS), env.get("LD_LIBRARY_PATH", "")) if p
    )
    return env


def _make_dynamic_writable(src: Path, dst: Path) -> None:
    """Copy an ELF64 little-endian executable, adding PF_W to loads that cover ``.dynamic``."""
    data = bytearray(src.read_bytes())
    if data[:4] != b"\x7fELF" or data[4] != 2 or data[5] != 1:
        raise RuntimeError(f"{src} is not a 64-bit little-endian ELF file")
    (phoff,) = struct.unpack_from("<Q", data, 0x20)
    phentsize, phnum = struct.unpack_from("<HH", data, 0x36)
    headers = []
    for i in range(phnum):
        off = phoff + i * phentsize
        p_type, p_flags, _, p_vaddr, _, _, p_memsz, _ = struct.unpack_from("<IIQQQQQQ", data, off)
        headers.append((off, p_type, p_flags, p_vaddr, p_memsz))
    dynamic = [(va, va + size) for _, t, _, va, size in headers if t == _PT_DYNAMIC]
    for off, p_type, p_flags, vaddr, memsz in headers:
        first, end = vaddr & ~0xFFF, (vaddr + memsz + 0xFFF) & ~0xFFF
        if p_type == _PT_LOAD and any(first < hi and lo < end for lo, hi in dynamic):
            struct.pack_into("<I", data, off + 4, p_flags | _PF_W)
    dst.write_bytes(bytes(data))
    dst.chmod(0o755)


def _runnable_idlc(workdir: Path) -> Path:
    shipped = WHEEL / ".libs" / "idlc"
    if not shipped.is_file():
        pytest.fail(f"no idlc in the cyclonedds wheel at {shipped}")
    probe = subprocess.run([shipped, "-v"], capture_output=True, env=_idlc_env(), timeout=30)
    if probe.returncode == 0:
        return shipped
    patched = workdir / "idlc"
    _make_dynamic_writable(shipped, patched)
    return patched


def _python_backend() -> Path:
    found = sorted(WHEEL.glob("_idlpy*.so"))
    if not found:
        pytest.fail(f"no _idlpy plugin in the cyclonedds wheel at {WHEEL}")
    return found[0]


def _type_ids(cls: type[IdlStruct]) -> list[str]:
    info = cls.__idl__.get_type_info()
    return [
        info.complete.typeid_with_size.type_id.serialize().hex(),
        info.minimal.typeid_with_size.type_id.serialize().hex(),
    ]


@pytest.fixture(scope="module")
def compiled(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[str]]:
    """Type name -> [complete id, minimal id] of every struct compiled from the IDL."""
    work = tmp_path_factory.mktemp("idlc")
    idlc = _runnable_idlc(work)
    out = work / "out"
    out.mkdir()
    shutil.copy(IDL_FILE, work / IDL_FILE.name)
    done = subprocess.run(
        [idlc, "-l", _python_backend(), IDL_FILE.name],
        cwd=work,
        capture_output=True,
        text=True,
        env=_idlc_env(),
        timeout=60,
    )
    assert done.returncode == 0, f"idlc failed ({done.returncode}):\n{done.stdout}{done.stderr}"
    moved = work / "paramdds"
    assert moved.is_dir(), f"idlc wrote no paramdds package: {sorted(p.name for p in work.iterdir())}"
    shutil.move(moved, out / "paramdds")
    child = subprocess.run(
        [sys.executable, "-c", _CHILD, str(out)],
        cwd=out,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert child.returncode == 0, child.stderr
    result: dict[str, list[str]] = json.loads(child.stdout)
    return result


def _python_structs() -> dict[str, type[IdlStruct]]:
    return {
        cls.__idl_typename__: cls
        for cls in vars(types).values()
        if isinstance(cls, type) and issubclass(cls, IdlStruct) and cls is not IdlStruct
    }


def test_same_type_names(compiled: dict[str, list[str]]) -> None:
    assert sorted(compiled) == sorted(_python_structs())


@pytest.mark.parametrize("typename", sorted(_python_structs()))
def test_same_type_identifier(compiled: dict[str, list[str]], typename: str) -> None:
    complete, minimal = _type_ids(_python_structs()[typename])
    assert typename in compiled, f"{typename} is in types.py but not in {IDL_FILE.name}"
    assert compiled[typename][0] == complete, f"{typename}: complete type id differs from the IDL"
    assert compiled[typename][1] == minimal, f"{typename}: minimal type id differs from the IDL"


def _members(struct: str) -> list[str]:
    body = IDL_FILE.read_text().split(f"struct {struct} {{", 1)[1].split("};", 1)[0]
    lines = (line.split("//", 1)[0].strip() for line in body.splitlines())
    return [line for line in lines if line]


def test_a_set_request_ends_with_its_deadline_then_its_author() -> None:
    # wire breaks before 1.0 (docs/wire.md): int64 deadline (ns since the Unix epoch by the caller's
    # clock), then the asker's claimed identity and channel, appended in both places
    assert _members("SetParametersRequest")[-3:] == ["int64 deadline;", "string who;", "string via;"]
    fields = list(types.SetParametersRequest.__dataclass_fields__)
    assert fields[-3:] == ["deadline", "who", "via"] and types.SetParametersRequest().deadline == 0


def test_the_state_ends_with_its_blame() -> None:
    blame = ["uint64 incarnation;", "string who;", "boolean verified;", "string via;"]
    assert _members("ParameterEvent")[-4:] == blame
    assert list(types.ParameterEvent.__dataclass_fields__)[-4:] == ["incarnation", "who", "verified", "via"]
