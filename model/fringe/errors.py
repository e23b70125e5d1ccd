"""The one exception type for bad user input (files, JSON, options)."""


class FringeInputError(Exception):
    """Bad input: the CLI prints `fringe: <message>` on one line and exits with status 2.

    The message names the file, the line or column where it can, and the problem.
    """

    def __init__(self, message: str, path: str | None = None, where: str | None = None):
        parts = [p for p in (path, where) if p]
        prefix = ":".join(str(p) for p in parts)
        text = f"{prefix}: {message}" if prefix else message
        super().__init__(_one_line(text))


def _one_line(text: str) -> str:
    """Control characters from the user's files (a NUL in a header, a newline in a name) shown escaped, so the
    message stays one printable line."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
