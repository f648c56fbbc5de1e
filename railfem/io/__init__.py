"""Readers and writers at the edge of railfem (files in, objects out)."""
