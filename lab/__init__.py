"""Lab code: evaluation, benchmarks, fault injection, fakes and the docs generator; tests and tools
import it, the wheel does not carry it."""
