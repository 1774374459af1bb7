"""Background traffic: free-moving kinematic strategies, and SUMO through libsumo."""
