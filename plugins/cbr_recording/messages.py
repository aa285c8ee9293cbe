"""The message types of a recording: the ROS 2 Humble type store, which gives every schema,
and :data:`DECISION`, cbrcore's own type, whose definition travels in the recording as every
schema does (Foxglove and the MCAP tools read it from there)."""

from __future__ import annotations

from typing import Any

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

DECISION = "cbrcore_msgs/msg/Decision"
"""The type of a consultation of the engine."""

DECISION_DEFINITION = """\
# One consultation of the CBR engine, stamped with the simulation time it was made at.
builtin_interfaces/Time stamp
# the consultation's number in the run: the query column of results.csv
uint32 query
# where the answer came from: casebase, solver:<name> or none
string source
# the best retrieved case (empty when none was retrieved)
string case_id
# its similarity in [0, 1] (NaN when nothing was retrieved)
float64 similarity
# how many cases the retrieval returned
uint32 retrieved
# why the fallback solver answered (empty when the case base did)
string fallback_reason
# what the family made of the answer, in words: the behaviors installed, the action taken
string action
# the wall time the engine took to answer (retrieve to the fallback solver), in milliseconds
float64 plan_ms
# each phase the engine ran, in order: its wall time and what it answered
string phases
# the family's detail as one JSON object
string detail
"""


def typestore() -> Any:
    """The ROS 2 Humble type store with cbrcore's :data:`DECISION` added."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(DECISION_DEFINITION, DECISION))
    return store
