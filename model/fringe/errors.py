"""The one exception type for bad user input (files, JSON, options)."""


class FringeInputError(Exception):
    """Bad input: the CLI prints `fringe: <message>` on one line and exits with status 2.

    The message names the file, the line or column where it can, and the problem.
    """

    def __init__(self, message: str, path: str | None = None, where: str | None = None):
        parts = ["''" if path == "" else path, where]     # an empty name is named as such
        prefix = ":".join(str(p) for p in parts if p)
        text = f"{prefix}: {message}" if prefix else message
        super().__init__(_short(_one_line(text)))


#: the longest message: a header or a name echoed from the user's file is cut in the middle beyond it
MAX_MESSAGE = 400


def _short(text: str) -> str:
    if len(text) <= MAX_MESSAGE:
        return text
    cut = len(text) - MAX_MESSAGE
    return f"{text[:MAX_MESSAGE * 2 // 3]} [... {cut} characters ...] {text[-MAX_MESSAGE // 3:]}"


def _one_line(text: str) -> str:
    """Control characters from the user's files (a NUL in a header, a newline in a name) shown escaped, so the
    message stays one printable line."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
