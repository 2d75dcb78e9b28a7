"""Tools over the library: benchmarks (:mod:`.bench`), stress cases (:mod:`.stress`), the Dask
sweep over scenes, views and presets (:mod:`.sweep`) and the reports (:mod:`.report_html`).
"""
