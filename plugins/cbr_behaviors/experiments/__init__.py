"""The RUPART experiment: ``rupart-delivery`` (:mod:`.delivery`)."""
