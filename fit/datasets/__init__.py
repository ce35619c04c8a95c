"""Data the project generates itself: the synthetic scan and the scattered-data test functions."""
