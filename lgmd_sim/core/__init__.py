"""The infrastructure every other floor stands on: named, checked parameters (`params`),
atomic files and bounded reads (`fileio`), resumable run folders (`runs`), running jobs
in processes or on Ray (`parallel`; a job and what its process keeps, `jobs`; the worker
processes, `pool`), registries of named classes (`registry`), optional dependencies
(`extras`), the machine's description (`machine`), the packaged data (`resources`), the
grey-frame convention (`frames`) and figure conventions (`plots`).
Nothing here imports the rest of lgmd_sim."""
