"""The two errors a user sees as one line (exit 2), from modules that import nothing: the command line can name
them without loading numpy, pandas or jsonschema (issue 26: `mrhyst --help` at once)."""

from mrhyst.data.errors import InputError  # noqa: F401  (the one class; mrhyst.data imports nothing)


class ConfigError(Exception):
    """The one line to show for a bad config."""
