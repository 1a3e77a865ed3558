"""The values of the command line's options, each checked as argparse reads it: a bad one is one line
naming what is valid (argparse's `error: argument --states: must be from 1 to 100000, got 0`)."""

from __future__ import annotations

import argparse
from pathlib import Path

MAX_STATES = 100_000  # random states per system: 1e5 evaluate in about a minute; more is a typo

MAX_SEED = 2**63 - 1


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if value < 1 or value > MAX_STATES:
        raise argparse.ArgumentTypeError(f"must be from 1 to {MAX_STATES}, got {value}")
    return value


def state_count(text: str) -> int:
    """`--states N`: a count on every command; a file name here is pointed to --states-file."""
    try:
        int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"'{text}' is not a whole number (--states N is a count of random states; "
            "a file of states is --states-file FILE)"
        ) from None
    return positive_int(text)


def probe_count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if not 0 <= value <= 100:
        raise argparse.ArgumentTypeError(f"must be from 0 to 100, got {value}")
    return value


def seed_arg(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be from 0 to 2**63 - 1, got {value}")
    return value


def path_arg(text: str) -> Path:
    """A path argument; the empty string is refused (Path('') would silently mean '.')."""
    if not text.strip():
        raise argparse.ArgumentTypeError("must not be empty (use . for the current folder)")
    return Path(text)


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not (value > 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a positive finite number, got {text}")
    return value
