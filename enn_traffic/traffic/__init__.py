"""Background traffic: free-moving kinematic strategies (and, later, SUMO through libsumo)."""
