"""Register maps shared by the daemon (`vdevd`) and the client (`vdevclient`): one source per map.

One module per card type (`vdevmaps.oms`, `vdevmaps.pmac`, `vdevmaps.galil`, ...): offsets, bit
fields and sizes as the manual names them, pure constants with no imports from either side, so the
client never imports the daemon and neither keeps a copy of the other's numbers.
"""
