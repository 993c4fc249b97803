def recording_damage(w): return []
