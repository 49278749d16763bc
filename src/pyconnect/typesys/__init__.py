"""The type model at the bottom of pyconnect: ROS interface types and their definition text.

- ``model``: frozen dataclasses (messages, fields, services, actions, packages, type sets)
- ``primitives``: the one table of primitive types (ranges, sizes, struct and numpy codes)
- ``names``: type-name parsing and the names of service and action parts
- ``packages``, ``parse``, ``from_rosidl``, ``loading``: definitions (installed packages, bare
  folders, .msg/.srv/.action/.idl text) into the model, with rosidl's parsers
- ``hashing``: RIHS01 type hashes
- ``installed_definition_text``: the definition text bags store, written for installed types;
  ``definition_text``: such text read back into the model
- ``classes``: the model read from installed rosidl Python classes

It imports nothing of pyconnect but ``pyconnect.errors``; everything else builds on it.
"""
