"""Contacts: the feet's support and swing phases (:mod:`~imesh.contacts.phases`) and the
support-foot constraints they put on the morph (:mod:`~imesh.contacts.support`; Nakaoka &
Komura 2012, sec. V-B)."""
