"""Fast DDS's default participant profile for the bridge's ROS 2 participant: type lookup off.

Fast DDS 3.2 can crash (SIGSEGV) in XTypes type lookup, which it runs for every remote
endpoint of a type it does not know: while the reply for a type is handled
(``TypeLookupManager::notify_callbacks``, on its reply thread, without a lock), discovery of
more endpoints of that type appends to the same list of callbacks (under a lock the reply
thread does not take), and a reallocation leaves the reply thread calling freed memory.
With the participant property ``fastdds.type_propagation`` = ``disabled`` Fast DDS makes no
type lookup service (``BuiltinProtocols``): a remote endpoint is matched by type name at
once (the fallback of ``EDPSimpleListeners``), and the participant's own endpoints carry no
type information, so no peer asks it for a type either.

rmw_fastrtps makes its participant with Fast DDS's default participant QoS, read from the
default profiles file (``FASTDDS_DEFAULT_PROFILES_FILE``), which Fast DDS loads once per
process, with the process's first participant. :func:`type_lookup_off` names a temporary
file while that participant is made: :data:`TYPE_LOOKUP_OFF_XML`, or the user's own
profiles file with the property set in its default participant profile (added when it has
none; a value it sets itself holds), so the user's settings hold too.
"""

from __future__ import annotations

import logging
import os
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

log = logging.getLogger(__name__)

PROFILES_ENV = "FASTDDS_DEFAULT_PROFILES_FILE"  # Fast DDS's default profiles file
LEGACY_PROFILES_ENV = "FASTRTPS_DEFAULT_PROFILES_FILE"  # the older name rmw_fastrtps still honours
PROPERTY = "fastdds.type_propagation"
OFF = ("disabled", "registration_only")  # the values with which Fast DDS makes no type lookup service
NAMESPACE = "http://www.eprosima.com"
TYPE_LOOKUP_OFF_XML = f"""<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns="{NAMESPACE}">
  <profiles>
    <participant profile_name="paramdds_bridge_ros2_side" is_default_profile="true">
      <rtps>
        <propertiesPolicy>
          <properties>
            <property>
              <name>{PROPERTY}</name>
              <value>disabled</value>
            </property>
          </properties>
        </propertiesPolicy>
      </rtps>
    </participant>
  </profiles>
</dds>
"""

_loaded = False  # whether this process made its first ROS 2 participant (Fast DDS read its profiles)


def _local(tag: str) -> str:
    return tag.rpartition("}")[2]


def _child(parent: ET.Element, name: str, ns: str) -> ET.Element:
    """``parent``'s first child named ``name`` (in any namespace), made when it has none."""
    for child in parent:
        if _local(child.tag) == name:
            return child
    return ET.SubElement(parent, ns + name)


def with_type_lookup_off(text: str) -> tuple[str, str]:
    """A Fast DDS profiles document (``<dds><profiles>`` or ``<profiles>``) with
    ``fastdds.type_propagation`` = ``disabled`` in its default participant profile, which is
    added when it has none; every other setting as it was, and a value the document sets
    itself kept. Returns the document and the value that holds. ``ValueError`` when it is
    not a profiles document."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise ValueError(f"not XML: {exc}") from None
    ns = root.tag[: root.tag.index("}") + 1] if root.tag.startswith("{") else ""
    if _local(root.tag) == "dds":
        profiles = next((c for c in root if _local(c.tag) == "profiles"), None)
        if profiles is None:
            profiles = ET.SubElement(root, ns + "profiles")
    elif _local(root.tag) == "profiles":
        profiles = root
    else:
        raise ValueError(f"the root element is <{_local(root.tag)}>, not <dds> or <profiles>")
    default = next(
        (
            p
            for p in profiles
            if _local(p.tag) == "participant" and p.get("is_default_profile", "").strip().lower() == "true"
        ),
        None,
    )
    if default is None:
        default = ET.SubElement(profiles, ns + "participant")
        default.set("profile_name", "paramdds_bridge_ros2_side")
        default.set("is_default_profile", "true")
    properties = _child(_child(_child(default, "rtps", ns), "propertiesPolicy", ns), "properties", ns)
    for prop in properties:
        fields = {_local(c.tag): (c.text or "").strip() for c in prop}
        if fields.get("name") == PROPERTY:
            return text, fields.get("value", "")
    prop = ET.SubElement(properties, ns + "property")
    ET.SubElement(prop, ns + "name").text = PROPERTY
    ET.SubElement(prop, ns + "value").text = "disabled"
    if ns:
        ET.register_namespace("", ns[1:-1])  # Fast DDS matches element names without a prefix
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(
        root, encoding="unicode"
    ) + "\n", "disabled"


@contextmanager
def type_lookup_off() -> Iterator[bool]:
    """Around the making of this process's first ROS 2 participant: the default profiles file
    sets ``fastdds.type_propagation`` to ``disabled`` (the module docstring). Yields whether
    type lookup is off: not when this process made a ROS 2 participant before (its profiles
    are loaded), when the user's profiles file sets another value itself, or when it cannot be
    read (said once; theirs is then used as it is)."""
    global _loaded
    if _loaded:
        yield False
        return
    variable = next((v for v in (PROFILES_ENV, LEGACY_PROFILES_ENV) if os.environ.get(v)), "")
    text, value = TYPE_LOOKUP_OFF_XML, "disabled"
    if variable:
        try:
            text, value = with_type_lookup_off(Path(os.environ[variable]).read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            log.warning(
                "%s=%s: %s; the bridge's ROS 2 participant keeps Fast DDS's type lookup",
                variable,
                os.environ[variable],
                exc,
            )
            _loaded = True
            yield False
            return
    before = os.environ.get(PROFILES_ENV)
    fd, path = tempfile.mkstemp(prefix="paramdds-fastdds-", suffix=".xml")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.environ[PROFILES_ENV] = path
        yield value in OFF
    finally:
        _loaded = True
        if before is None:
            os.environ.pop(PROFILES_ENV, None)
        else:
            os.environ[PROFILES_ENV] = before
        os.unlink(path)
