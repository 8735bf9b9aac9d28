"""Layer 5, studies: TOML study files, runs, tidy results, Monte Carlo campaigns."""
