"""Scripted virtual experiments (column collapse of the thesis' forward tables)."""
