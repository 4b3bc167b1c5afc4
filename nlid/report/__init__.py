"""Presentation shared by every result: the one Summary type and the figure helpers."""
