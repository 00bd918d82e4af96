"""The assignment's figures, drawn headless (matplotlib Agg): one module per figure set.

Each module exposes ``make_figures(out_dir: Path, seed: int) -> list[Path]`` and writes PNGs that depend only
on the seed.
"""
