"""Numbers for people: shared by the progress display (litl.loop) and the report (litl.report),
without either importing the other."""

import math


def format_number(value: float | None, spec: str = ".4g") -> str:
    """`value` with significant digits (`spec`), "—" if it is None or not finite, never "-0".

    Args:
      value: a number or None.
      spec: a numeric format specification, e.g. ``".4g"`` or ``".3e"``.
    """
    if value is None or not math.isfinite(value):
        return "—"
    text = format(value, spec)
    # -0.0, or a tiny negative rounded away (-1e-7 as ".3f"), would print as a negative zero.
    if text.startswith("-") and not any(c in "123456789" for c in text[1:].lower().split("e")[0]):
        text = text[1:]
    return text
