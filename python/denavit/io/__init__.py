"""The edge layer: every file format and every unit of denavit, in one place.

Inside, denavit is SI (metres, radians, kilograms); units exist only at the boundary, where a file or the
command line declares them. This package owns

- :mod:`denavit.io.units`: unit names and scales, the one parser of ``# units:`` declarations, the one
  per-joint-kind scale rule (:func:`~denavit.io.units.joint_scale`);
- :mod:`denavit.io.text`: reading text files (UTF-8 with or without BOM; anything else is a one-line error);
- :mod:`denavit.io.output`: writing files whole or not at all;
- the formats: :mod:`~denavit.io.robotfile` (TOML robot files), :mod:`~denavit.io.urdf` (URDF in and out),
  :mod:`~denavit.io.sweeps` (sweep CSV, per-joint files, JSON), :mod:`~denavit.io.configurations` (CSV of joint
  configurations).

Readers of each format build on these; nothing else in the package scales units or opens files.
"""
