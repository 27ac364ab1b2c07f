"""Ashore, across a fleet: every vessel's logs estimated as tasks on Dask distributed, the
results kept in Parquet between runs, and each clearance's wear trend with the date it
reaches its limit. Dask and pyarrow are ashore dependencies (the ``ashore`` extra), never
the node's: nothing here is imported by the vessel side."""
