"""COPC inputs are written as plain LAZ: the COPC info VLR and hierarchy EVLR are dropped (a
plain LAZ writer cannot keep the octree they index)."""
from __future__ import annotations

#: User id of the COPC info VLR and hierarchy EVLR.
COPC_USER_ID = "copc"


def without_copc(records):
    """``records`` (VLRs or EVLRs) but the COPC ones, as the VLRList laspy's writer takes."""
    from laspy.vlrs.vlrlist import VLRList

    return VLRList([v for v in records if v.user_id != COPC_USER_ID])


def drop_copc(header):
    """Remove the COPC records from ``header``; True if there were any."""
    found = False
    for records in (header.vlrs, header.evlrs):
        if records is None:
            continue
        copc = [v for v in records if v.user_id == COPC_USER_ID]
        for v in copc:
            records.remove(v)
        found = found or bool(copc)
    return found
