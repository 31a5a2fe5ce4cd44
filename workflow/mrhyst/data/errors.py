"""The one exception of a user's mistake (its own module so that every reader can raise it)."""


class InputError(Exception):
    """A user's file or setting is wrong; the message is the one line to show."""
