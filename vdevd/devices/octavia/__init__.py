"""The DSP Control Group PCI Mx4 Octavia card (type `dspcg-octavia`): README.md in this package."""
