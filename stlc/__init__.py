"""stlc — a compiler for a Signal Temporal Logic mission language."""

__version__ = "0.1.0"
