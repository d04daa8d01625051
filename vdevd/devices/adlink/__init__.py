"""ADLINK AMP-204C/208C pulse motion card (spec: /work/shared/spec/adlink.md)."""
