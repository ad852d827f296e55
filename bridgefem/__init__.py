"""bridgefem: limit loads of masonry arch bridges (elastic voussoirs, unilateral frictional joints)."""
