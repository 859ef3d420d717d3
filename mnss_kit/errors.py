"""The one exception type for user mistakes.

Raise ``UserError`` for anything the user can fix (bad path, corrupt file,
wrong scale, NaN pixels, unknown config key).  The CLI prints its message on
one line and exits with status 2; every other exception is a bug and keeps
its traceback.
"""


class UserError(Exception):
    """A problem with the user's input, reported as one line without a traceback."""
