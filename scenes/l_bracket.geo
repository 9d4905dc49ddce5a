// L-shaped bracket for scenes/l_bracket.toml: a 100 mm x 100 mm L of 20 mm legs, 20 mm thick.
// Regenerate with: gmsh -3 -format msh41 -clmax 0.008 scenes/l_bracket.geo -o scenes/l_bracket.msh
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 0.1, 0.02, 0.02};
Box(2) = {0, 0, 0, 0.02, 0.1, 0.02};
BooleanUnion(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
e = 1e-6;
Physical Surface("clamp") = Surface In BoundingBox{-e, 0.1-e, -e, 0.02+e, 0.1+e, 0.02+e};
Physical Surface("load") = Surface In BoundingBox{0.1-e, -e, -e, 0.1+e, 0.02+e, 0.02+e};
Physical Volume("steel") = Volume{:};
