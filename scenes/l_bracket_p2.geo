// The L-bracket of l_bracket.geo meshed with 10-node tets (Gmsh element type 11, 6-node
// triangles in the surface groups) for scenes/l_bracket_p2.toml. The bracket is all planes, so
// the edge nodes sit at the edge midpoints (SecondOrderLinear keeps them there on any model).
// Regenerate with: gmsh -3 -format msh41 -clmax 0.01 scenes/l_bracket_p2.geo -o scenes/l_bracket_p2.msh
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 0.1, 0.02, 0.02};
Box(2) = {0, 0, 0, 0.02, 0.1, 0.02};
BooleanUnion(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
e = 1e-6;
Physical Surface("clamp") = Surface In BoundingBox{-e, 0.1-e, -e, 0.02+e, 0.1+e, 0.02+e};
Physical Surface("load") = Surface In BoundingBox{0.1-e, -e, -e, 0.1+e, 0.02+e, 0.02+e};
Physical Volume("steel") = Volume{:};
Mesh.ElementOrder = 2;
Mesh.SecondOrderLinear = 1;
