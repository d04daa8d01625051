"""The OMS MAXk PCI card (type `oms-maxk`): README.md in this package."""
