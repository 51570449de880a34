"""Baseline planners: random, GA with logic, exact (proven optimum), sequential single-item auction."""
