"""sphpost.exceptions: the error a user can fix."""


class PostprocError(Exception):
    """An error the user can fix (wrong directory, missing file, bad option):
    the scripts print its message alone and exit with status 2."""
