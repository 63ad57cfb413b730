"""The model benchmark: `lgmd-sim bench closed-loop` (controllers driving with each
detector, `closed_loop`) and `lgmd-sim bench open-loop` (every model on the same clips,
`open_loop`), their run folders (`runs`) and figures (`figures`)."""
