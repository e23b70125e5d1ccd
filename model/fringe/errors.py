"""The one exception type for bad user input (files, JSON, options)."""


class FringeInputError(Exception):
    """Bad input: the CLI prints `fringe: <message>` on one line and exits with status 2.

    The message names the file, the line or column where it can, and the problem.
    """

    def __init__(self, message: str, path: str | None = None, where: str | None = None):
        parts = [p for p in (path, where) if p]
        prefix = ":".join(str(p) for p in parts)
        super().__init__(f"{prefix}: {message}" if prefix else message)
