"""The file formats: ROS 2 parameter files, parameter lists, generate_parameter_library
specs, and the dump that takes them back (no DDS); and Autoware's JSON Schemas of parameter
files (:mod:`.schema`: declaring, enforcing, checking files offline, deriving one).

:mod:`.scalar` reads one typed value, :mod:`.base` holds what the formats share (sources,
composing them, reading a file with its name and line in every error), and :mod:`.ros`,
:mod:`.paramlist`, :mod:`.spec` and :mod:`.dump` are one format each; :mod:`.files` reads a
parameter file for a node whatever its format. :mod:`.recording` is the MCAP recording's
(``paramdds record``, ``history --from``): its channels, JSON Schemas and messages.
"""
