"""Unpickling of kanedyn objects: each is rebuilt from the text it was loaded from.

`Mechanism.__reduce__` and `Study.__reduce__` name these functions, so a pickle holds the file
text, its name and the load options, never Rust memory; loading it parses the text again exactly
as the original was parsed, so the copy computes the same numbers bit for bit.
"""

from ._kanedyn import Mechanism, Study


def restore_mechanism(text, name, allow_read, allow_any_path, max_file_kb, max_bodies):
    """A mechanism from its pickled state (see `Mechanism.__reduce__`)."""
    return Mechanism.from_str(
        text,
        name,
        allow_read=allow_read,
        allow_any_path=allow_any_path,
        max_file_kb=max_file_kb,
        max_bodies=max_bodies,
    )


def restore_study(
    text, name, allow_read, allow_any_path, max_file_kb, max_bodies, max_memory_mb, max_output_mb, max_cpu_hours
):
    """A study from its pickled state (see `Study.__reduce__`)."""
    return Study.from_str(
        text,
        name,
        allow_read=allow_read,
        allow_any_path=allow_any_path,
        max_file_kb=max_file_kb,
        max_bodies=max_bodies,
        max_memory_mb=max_memory_mb,
        max_output_mb=max_output_mb,
        max_cpu_hours=max_cpu_hours,
    )
