"""Layer 2: optimal-control problems as Pyomo models and the solver session: the space-domain NLP
(from any state), time-domain legs, DAS phases and their mode choice, the prepared problem."""
