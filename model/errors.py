"""User-facing errors: raised for bad input, printed without a traceback by cli.py and reported by operators."""


class UserError(Exception):
    """An error the user can fix. The message names the file or value and what is wrong."""
