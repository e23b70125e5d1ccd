"""Test cases for a parameter's range check: the values just outside ``lo..hi`` (or the given ones),
each with the message the model raises, "<unit>: <NAME> = <value> out of range <lo>..<hi>"."""


def out_of_range(unit: str, field: str, lo: int, hi: int, hi_text: str | None = None,
                 values: tuple[int, ...] | None = None) -> list[tuple[dict, str]]:
    """``[({field: v}, message), ...]`` for v in ``values`` (default lo - 1 and hi + 1); NAME is
    ``field.upper()`` and ``hi_text`` replaces hi in the message (e.g. "min(10, FINE_W-1) = 10")."""
    rng = f"{lo}..{hi if hi_text is None else hi_text}"
    return [({field: v}, f"{unit}: {field.upper()} = {v} out of range {rng}") for v in (values or (lo - 1, hi + 1))]
