"""Figures, tables and reports built from the models (matplotlib lives here, not in sensor/)."""
