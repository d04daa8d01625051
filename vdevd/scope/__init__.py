"""The scope: a daemon-side recorder of per-axis signals of one card (issue 23 §1).

`signals` names what can be recorded and how a card maps it (`Signals`, one subclass per card
package in its `scope.py`), `trigger` is the sans-I/O trigger machine, `recorder` the bounded
ring buffer, `probe` attaches a recorder to a card's ticks, and `op` serves the `scope` request
(proto/PROTOCOL.md "Scope").
"""
