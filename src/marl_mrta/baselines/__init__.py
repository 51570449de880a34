"""Baseline planners and the reference: random, GA with logic, sequential single-item auction;
exact A*, the CP-SAT step model and the relaxation's lower bound (reference.py chooses)."""
