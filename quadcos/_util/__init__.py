"""Plumbing every layer may use: CLI errors (`cli`), the compilation caches (`caches`), quiet
third-party imports (`quiet`), dotted config overrides (`overrides`), versions and git revision
(`provenance`), atomic file writes (`files`)."""
