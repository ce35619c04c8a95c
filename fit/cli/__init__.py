"""The ``trispline`` command line."""
from .app import WEIGHT_FIELDS, build_parser, main

__all__ = ["WEIGHT_FIELDS", "build_parser", "main"]
