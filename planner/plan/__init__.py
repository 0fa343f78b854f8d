"""The tandem-plan/1 plan: typed nodes, load/save, walks."""
