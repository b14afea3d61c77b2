"""The package's one exception type for bad input."""


class InputError(ValueError):
    """Bad input: the message names the source (file), the field, the value and what is allowed.

    A ``ValueError``, so ``except ValueError`` keeps working; the command line prints it on one
    line and exits with status 2.
    """
