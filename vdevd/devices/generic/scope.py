"""What the scope records on the generic servo card (issue 23 §1; docs/card-pattern.md
"Scope"): the shared defaults over its motion core (`card.core`)."""

from __future__ import annotations

from vdevd.scope.signals import Signals

SIGNALS = Signals
