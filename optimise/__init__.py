"""Optimisation over ground-plane candidates: objective, nlopt loop, sweeps, reports."""
