"""Rough layered Bragg structures (Fourneau et al. 2024 §4): the ballistic transmission
filter F_α, integrated transmissivity, the single-reflection BRDF and a Monte Carlo reference."""

from .structure import LayeredBragg, RoughBraggLayer

__all__ = ["LayeredBragg", "RoughBraggLayer"]
