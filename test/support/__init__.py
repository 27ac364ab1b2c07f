"""Helpers the tests share (no test here)."""
