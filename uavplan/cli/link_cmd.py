"""Placeholder module; commands are added by their issue."""
