"""Data tables of uw3p (installed as the resource package ``uw3p_data``); see README.md here."""
