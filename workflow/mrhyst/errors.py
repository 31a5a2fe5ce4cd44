"""The two errors a user sees as one line (exit 2), in a module that imports nothing: the command line can
name them without loading numpy, pandas or jsonschema (issue 26: `mrhyst --help` at once)."""


class InputError(Exception):
    """A user's file or setting is wrong; the message is the one line to show."""


class ConfigError(Exception):
    """The one line to show for a bad config."""
