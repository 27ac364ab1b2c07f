"""Studies ashore and on the desk: the paper-level tables (:mod:`.tables`), their plots
(:mod:`.plots`) and the accuracy study of the estimation over simulated voyages
(:mod:`.accuracy`). The node never imports them."""
