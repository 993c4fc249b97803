"""Lab-only code (evaluation, benchmarks, fault injection, fakes): in the repository, not in the wheel."""
