"""Packaged QoS profiles (``DDS_QOS_PROFILES.xml``), found with ``importlib.resources``."""
