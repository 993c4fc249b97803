"""EUROCONTROL ASTERIX for a VTS: CAT 010 edition 1.1 target reports and status, CAT 034 service
messages, as bytes. Pure: values in, bytes out, no I/O, no clock.

`items` packs single data items (bit layouts, LSBs, rounding and saturation), `blocks` the
FSPEC, records and data blocks of at most 1,472 bytes, `cat010` turns a `ShipFix` into a target
report record and a health state into status records, `cat034` the optional service messages.
The transport is `edge.outputs.asterix`; the interface control document is docs/asterix-icd.md.
"""
