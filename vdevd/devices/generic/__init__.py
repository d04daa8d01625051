"""The generic servo card: the platform's reference card (README.md)."""
