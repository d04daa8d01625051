"""Galil DMC-13X8 (VME) virtual card: A16 window, interrupts, DMC command interpreter (README.md)."""
