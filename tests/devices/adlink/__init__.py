"""Tests of the ADLINK AMP-204C / AMP-208C modules."""
