"""cocotb, or None where it is not installed: a block test's pytest side (the launcher) is collected
without it, its cocotb side is defined only under ``if cocotb is not None``."""

try:
    import cocotb
except ImportError:  # pragma: no cover - pytest collection without cocotb: only the launcher is needed
    cocotb = None

__all__ = ["cocotb"]
