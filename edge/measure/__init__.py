"""The per-pair measurement chain, between the frame pair and the list of fixes.

`detect` finds ships in the left image; `tracks` keeps the track table (ids, Q/T/L, association
with `boxes`); `point` is one track's point (reference by `anchor`, left follow, right match),
its disparity filter is `pointfilter`, designed from the ship-motion bound by `ranging`; `batch`
answers all tracks' core requests together; `settings` holds the knobs every track shares;
`coast` carries a track's last measured fix over a pair in which its point cannot be ranged on.
Nothing here does I/O or encodes an output.
"""
