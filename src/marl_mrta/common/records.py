"""Dataclass options shared by the per-step records.

`slots=True` (Python >= 3.10) makes the records of every decision step smaller and faster to
read; Noetic's system Python is 3.8, where dataclass() does not take it, so there they are
plain dataclasses with the same fields and behaviour.
"""
import sys

#: Keyword arguments for @dataclass(**STEP_RECORD) on records built every decision step.
STEP_RECORD = {"slots": True} if sys.version_info >= (3, 10) else {}
