"""Assemblies of rigid bodies under uniform gravity: contacts, the stability LP and the stable region."""
