"""The shore side: what reads a vessel's logs after the fact, never imported by the node.

* :mod:`~steer_monitor.ashore.replay` runs the node's own pipeline over logs into MCAP, the
  same bytes the node would have written (its estimator jobs run ahead in
  :mod:`~steer_monitor.ashore.replay_worker`);
* :mod:`~steer_monitor.ashore.reviewlogs` reads logs in blocks of columns into
  :mod:`~steer_monitor.ashore.review`, fast; :mod:`~steer_monitor.ashore.report` makes the HTML pages;
* :mod:`~steer_monitor.ashore.fleet` estimates every vessel's logs as tasks on Dask
  distributed, keeps the results in Parquet between runs (:mod:`~steer_monitor.ashore.store`)
  and gives each clearance's wear trend with the date it reaches its limit. Dask and pyarrow
  are the ``ashore`` extra's dependencies, imported by the fleet's modules only.
"""
